"""Result pages and tables that evaluate policies handed to them (never imported by name).

- ``provenance``: how and where a page was made (command line, machine).
- ``paper_table``: reference returns of the 16 paper configurations beside Table I.
- ``planners``: classical multi-crane planners on the shipped scenarios; ``planners_tables``
  formats them and ``planners_page`` writes the markdown page with its observations.
"""

"""Result pages and tables that evaluate policies handed to them (never imported by name).

- ``provenance``: how and where a page was made (command line, machine).
- ``paper_table``: reference returns of the 16 paper configurations beside Table I.
- ``planners``: classical multi-crane planners on the shipped scenarios; ``planners_tables``
  makes their tables' rows, ``planners_notes`` the observations and ``planners_page`` the
  markdown page.
- ``comparison_plot``: the comparison commands' ``--plot``: per-episode strips and learning
  curves, drawn from the panels ``comparison_data`` makes of each command's results.

May import: every room below it (``core`` to ``benchmark``) and the public face
(``multicrane``).
"""

"""The ground floor: the scenario schema and the integer codes that every room shares.

May import: nothing of multicrane's. Everything else may import it.
"""

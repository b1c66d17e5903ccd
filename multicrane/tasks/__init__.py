"""Task-level machinery: the task book (each crane's (component, target) task), the carrier
that moves components along reserved space-time paths, and the reservations.

May import: ``core``, ``sim`` and ``scenario``.
"""

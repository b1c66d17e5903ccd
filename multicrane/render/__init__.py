"""Pictures of a site: the text render, the ``rgb_array`` picture and episode videos, and the
rerun scene, viewer lookup and live stream of ``render_mode="human"``.

May import: ``core``, ``sim`` and ``scenario``.
"""

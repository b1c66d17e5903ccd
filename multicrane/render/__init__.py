"""Pictures of a site: the text render and the rerun scene and live stream of
``render_mode="human"``.

May import: ``core``, ``sim`` and ``scenario``.
"""

"""Policies for multicrane: baselines, planners and learned agents.

Every policy here acts through the environments' own interfaces (observations and masks, or
the simulator state they expose), so any of them can be evaluated and recorded the same way.
"""

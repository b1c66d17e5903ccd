"""The RL adapters: the PettingZoo multi-agent environment and its decision modes, the
Gymnasium paper environment and joint (all cranes, one agent) environment, observations,
rewards, infos and the checks at their boundary.

May import: ``core``, ``sim``, ``scenario``, ``render`` and ``tasks``.
"""

"""The paper's Table I, and how its columns relate to this project's algorithms.

Table I (Zhu et al.) gives, per configuration, the mean return +- standard error over 15
training seeds of four algorithms it calls "DQN", "DDQN", "A2C" and "PPO". The public code
behind it ran other algorithms than those names say (``docs/paper-spec.md`` section 7, item
10): its "DQN" was a double DQN (the library's default) and its "DDQN" a dueling double
DQN. ``PAPER_COLUMN`` therefore puts each Table I column beside the closest algorithm of
ours: both value-based columns beside our ``double_dqn``; our plain ``dqn`` has no
counterpart in the paper, nor has ``maskable_ppo``.
"""

from __future__ import annotations

ALGORITHMS = ("DQN", "DDQN", "A2C", "PPO")

# Table I of the paper: (mean, standard error) per algorithm, in ALGORITHMS order. The
# paper's "DQN" was a double DQN and its "DDQN" a dueling double DQN (docs/paper-spec.md
# item 10); the names are the paper's.
TABLE_I: dict[str, tuple[tuple[float, float], ...]] = {
    "E1S1": ((-5.16, 0.49), (-4.27, 0.42), (-42.57, 15.60), (-19.03, 7.34)),
    "E1S2": ((-2.94, 0.14), (-4.36, 0.99), (-140.61, 16.07), (-55.46, 12.13)),
    "E1S3": ((-2.62, 0.30), (-2.62, 0.32), (-97.42, 7.01), (-46.89, 8.86)),
    "E1S4": ((-3.37, 0.32), (-3.16, 0.14), (-161.02, 13.10), (-57.80, 13.09)),
    "E2S1": ((-12.40, 3.76), (-18.42, 5.90), (-95.45, 10.49), (-48.87, 2.73)),
    "E2S2": ((-47.27, 7.94), (-21.76, 5.90), (-153.80, 7.35), (-52.17, 5.67)),
    "E2S3": ((-6.16, 0.40), (-12.27, 5.75), (-110.95, 13.17), (-38.93, 4.42)),
    "E2S4": ((-32.36, 7.09), (-38.63, 7.83), (-123.76, 9.77), (-54.40, 7.64)),
    "E3S1": ((-277.28, 10.29), (-409.16, 15.14), (-543.08, 11.76), (-204.94, 33.17)),
    "E3S2": ((-232.77, 12.97), (-319.96, 34.05), (-535.54, 17.38), (-183.85, 41.07)),
    "E3S3": ((-258.80, 8.06), (-373.12, 16.29), (-415.12, 28.28), (-111.22, 6.13)),
    # PPO printed as "140.18": the minus sign was lost (docs/paper-spec.md section 7, item 9).
    "E3S4": ((-239.68, 10.29), (-362.18, 28.83), (-527.82, 16.68), (-140.18, 7.48)),
    "E4S1": ((-907.31, 25.98), (-1091.58, 17.01), (-1148.31, 13.42), (-466.27, 70.70)),
    "E4S2": ((-593.04, 28.46), (-978.52, 47.37), (-1160.99, 4.69), (-437.76, 89.00)),
    "E4S3": ((-900.72, 15.95), (-1080.51, 9.15), (-1127.31, 9.10), (-388.21, 58.61)),
    "E4S4": ((-614.14, 24.60), (-1022.09, 24.89), (-1160.34, 7.75), (-300.97, 57.27)),
}
SIGN_FIXED = {"E3S4"}

# What each Table I column really ran, for captions.
PAPER_MEANING = {
    "DQN": "double DQN",
    "DDQN": "dueling double DQN",
    "A2C": "A2C",
    "PPO": "PPO",
}

# Our algorithm -> the Table I columns shown beside it (closest algorithm first).
PAPER_COLUMN: dict[str, tuple[str, ...]] = {
    "dqn": (),
    "double_dqn": ("DQN", "DDQN"),
    "a2c": ("A2C",),
    "ppo": ("PPO",),
    "maskable_ppo": (),
    "lean_ppo": ("PPO",),
}

# The seeds behind every Table I entry.
PAPER_SEEDS = 15
PAPER_STEPS = 1_000_000


def table_i(config: str, column: str) -> tuple[float, float] | None:
    """Table I's (mean, standard error) of ``column`` in ``config``; None when the paper
    has no such configuration."""
    entries = TABLE_I.get(config.upper())
    if entries is None:
        return None
    if column not in ALGORITHMS:
        raise KeyError(f"Table I has no column {column!r}: one of {', '.join(ALGORITHMS)}")
    return entries[ALGORITHMS.index(column)]

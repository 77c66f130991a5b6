"""Standard control tasks with hard margins, the toolkit's agents beside Stable-Baselines3's.

The benchmark of ``docs/results/standard-tasks.md``: for each task and seed, SB3's TD3, SAC and
DDPG with the RL Zoo's hyperparameters, and the toolkit's DCP (as adopted and as the paper
gives it), DDPG and TD3 trained by ``host-trainer train --plant-cmd`` on the same Gymnasium
environment, the same number of environment steps, and the same test starts.

- :mod:`.tasks`: the tasks, their margins, the Zoo's hyperparameters and published scores.
- :mod:`.recorder`: one wrapper that measures every episode the same way for every agent
  (return, steps at the action bound, steps at the position limit, success).
- :mod:`.sb3_agents`: SB3's side (needs ``python/requirements-benchmark.txt``).
- :mod:`.grid`: the grid of runs, resumable, one folder per run.
- ``python3 -m margin_safe_rl.standard_tasks --help``: the command line.
"""

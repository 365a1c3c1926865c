"""Experiments on top of the policy plugin and the sim tasks (floor 4).

- ``fit``       ``forcemap fit``: dataset -> fitted forcemap checkpoint (in-process, the code path of
                ``lerobot-train --policy.type=forcemap --steps=1``)
- ``evaluate``  ``forcemap eval``: roll a checkpoint in a sim task, one JSON record per episode, next to
                the demonstrations' figures
- ``report``    ``forcemap report``: tables and plots from eval JSON
- ``demo``      ``make demo``: shipped press demos -> segment -> fit one-shot -> 20 episodes -> table,
                force profile, 3-D path and an eval video
"""

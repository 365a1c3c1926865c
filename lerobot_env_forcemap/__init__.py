"""LeRobot env plugin: `EnvConfig`s for the forcemap MuJoCo tasks (filled in by the envs work)."""

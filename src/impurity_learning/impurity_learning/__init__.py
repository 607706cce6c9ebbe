"""Learning for the impurity cell: DQN training, TCDD rewards, replay, the baselines and the paper's
evaluation, all in the PyBullet fast sim. Never installed on a real cell (the runtime lives in
impurity_policy, impurity_attention and the drivers)."""

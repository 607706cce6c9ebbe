"""Push-grasp DQN (FCAVF, TCDD reward), trainer, policy and episode nodes."""

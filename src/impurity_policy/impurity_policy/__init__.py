"""Push-grasp DQN with fully convolutional action-value functions, TCDD reward, trainer, policy and episode nodes."""

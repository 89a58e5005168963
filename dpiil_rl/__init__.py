"""dpiil_rl: safe interactive imitation learning on TorchRL."""

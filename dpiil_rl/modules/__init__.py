"""TensorDict modules: ensemble actor, speed head, risk gate, expert switch."""

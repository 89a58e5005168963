"""Tasks as TorchRL environments."""

"""The Hydra config tree (a package, so that an installed dpiil_rl finds it): one group per package, every key
commented."""

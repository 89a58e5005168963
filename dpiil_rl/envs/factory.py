"""``make_env``: build the task named by ``cfg.env`` (its ``_target_``) with a batch of environments."""

from __future__ import annotations

from typing import Any

from omegaconf import DictConfig, OmegaConf
from torchrl.envs import EnvBase

from dpiil_rl.utils.config import instantiate_checked as instantiate


def make_env(env_cfg: DictConfig | dict[str, Any], num_envs: int = 1, seed: int | None = None) -> EnvBase:
    """Instantiate the env config's ``_target_`` with ``num_envs`` parallel episodes (one process).

    Nested blocks (such as the task's scripted ``expert``) are passed through as plain dicts, not
    instantiated: the expert factory builds them against the env's geometry.
    """
    cfg = OmegaConf.create(env_cfg) if isinstance(env_cfg, dict) else env_cfg
    if "_target_" not in cfg:
        raise ValueError(f"env config {OmegaConf.to_container(cfg)!r}: expected a '_target_' naming the env factory")
    return instantiate(cfg, num_envs=num_envs, seed=seed, _recursive_=False, _convert_="all")

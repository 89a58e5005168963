"""``make_<group>`` factories: one per config group, shapes read from the env's specs (docs/design.md)."""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any, Mapping, Sequence, cast

import torch
from omegaconf import DictConfig, OmegaConf
from torchrl.envs import EnvBase, InitTracker, TransformedEnv

from dpiil_rl.collectors.intervention import InterventionCollector
from dpiil_rl.data.buffer import make_buffer
from dpiil_rl.envs.factory import make_env
from dpiil_rl.experts.base import ExpertSource
from dpiil_rl.hooks.base import LoopHook
from dpiil_rl.hooks.calibrate import CalibrateThresholdHook
from dpiil_rl.hooks.checkpoint import CheckpointHook
from dpiil_rl.hooks.dashboard import DashboardHook
from dpiil_rl.hooks.evaluate import EvaluateHook
from dpiil_rl.hooks.log_metrics import LogMetricsHook
from dpiil_rl.hooks.refit import RefitHook
from dpiil_rl.loggers.run_logger import RunLogger, run_display_name
from dpiil_rl.methods.base import Method
from dpiil_rl.modules.ensemble_actor import EnsembleActor
from dpiil_rl.modules.fitting import FitSettings
from dpiil_rl.modules.speed_head import SpeedHead
from dpiil_rl.modules.threshold import FixedThreshold
from dpiil_rl.records.checkpoints import latest_checkpoint, load_state
from dpiil_rl.records.run_files import RunFiles
from dpiil_rl.records.run_lock import hold_run_dir
from dpiil_rl.training.interactive_trainer import InteractiveTrainer
from dpiil_rl.utils.config import instantiate_checked as instantiate
from dpiil_rl.utils.specs import spec_bounds

# offsets that give every random stream of a run its own seed
EXPERT_SEED, EVAL_SEED, TRAIN_SEED = 1_000, 2_000, 3_000


def build_env(env_cfg: DictConfig, num_envs: int, seed: int) -> EnvBase:
    """The task env with an ``InitTracker`` (``is_init`` marks each episode's first step)."""
    return TransformedEnv(make_env(env_cfg, num_envs=num_envs, seed=seed), InitTracker())


def make_actor(actor_cfg: DictConfig, env: EnvBase, observation_key: str = "observation") -> EnsembleActor:
    obs_low, obs_high = spec_bounds(env.observation_spec[observation_key])
    act_low, act_high = spec_bounds(env.action_spec)
    return EnsembleActor(
        obs_low,
        obs_high,
        act_low,
        act_high,
        num_members=actor_cfg.num_members,
        hidden=list(actor_cfg.hidden),
        bootstrap=actor_cfg.bootstrap,
        observation_key=observation_key,
    )


def speed_head_inputs(ignore: Sequence[str], env: EnvBase, size: int) -> list[int] | None:
    """The observation dimensions a speed head reads when it ignores the env's state parts ``ignore``
    (names of ``env.observation_parts``); None (every dimension) when it ignores nothing."""
    if not ignore:
        return None
    parts: Mapping[str, slice] = getattr(env, "observation_parts", {}) or {}
    unknown = [name for name in ignore if name not in parts]
    if unknown:
        raise ValueError(
            f"modules.speed_head.ignore = {list(ignore)}: {unknown} not in this env's state parts; "
            f"expected names from {sorted(parts)}"
        )
    dropped = {i for name in ignore for i in range(size)[parts[name]]}
    kept = [i for i in range(size) if i not in dropped]
    if not kept:
        raise ValueError(f"modules.speed_head.ignore = {list(ignore)}: nothing of the state is left to read")
    return kept


def make_speed_head(speed_cfg: DictConfig, env: EnvBase, observation_key: str = "observation") -> SpeedHead:
    obs_low, obs_high = spec_bounds(env.observation_spec[observation_key])
    ignore = [str(x) for x in (speed_cfg.get("ignore") or [])]
    return SpeedHead(
        obs_low,
        obs_high,
        hidden=list(speed_cfg.hidden),
        min_sigma=speed_cfg.min_sigma,
        observation_key=observation_key,
        inputs=speed_head_inputs(ignore, env, int(obs_low.numel())),
    )


def make_method(method_cfg: DictConfig, chi: float | None = None, chi_quantile: float | None = None) -> Method:
    """The method of ``method_cfg``; with ``chi`` its threshold rule is replaced by ``FixedThreshold(chi)``
    (the sensitivity study). ``chi_quantile`` (a task protocol's choice, e.g. Table I's "χ at 50%") sets the
    quantile of a method whose χ is calibrated by quantile; methods without a threshold ignore it."""
    threshold = method_cfg.get("threshold") if "threshold" in method_cfg else None
    if chi is None and chi_quantile is not None and threshold is not None and "quantile" in threshold:
        spec = cast("dict[str, Any]", OmegaConf.to_container(method_cfg, resolve=True))  # a mapping's container
        spec["threshold"]["quantile"] = float(chi_quantile)
        method_cfg = OmegaConf.create(spec)
    if chi is not None:
        if "threshold" not in method_cfg:
            raise ValueError(
                f"chi = {chi}: method {method_cfg.get('name')!r} has no threshold χ to fix (expected chi=null)"
            )
        spec = cast("dict[str, Any]", OmegaConf.to_container(method_cfg, resolve=True))  # a mapping's container
        spec["threshold"] = {"_target_": f"{FixedThreshold.__module__}.{FixedThreshold.__name__}", "value": float(chi)}
        method_cfg = OmegaConf.create(spec)
    return instantiate(method_cfg, _convert_="all")


def make_expert(expert_cfg: DictConfig, env: EnvBase, seed: int) -> ExpertSource:
    return instantiate(expert_cfg, env=env, seed=seed, _convert_="none")


def make_logger(logger_cfg: DictConfig, run_dir: Path, cfg: DictConfig) -> RunLogger:
    config = OmegaConf.to_container(cfg, resolve=True)
    return instantiate(
        logger_cfg,
        run_dir=str(run_dir),
        exp_name=run_display_name(str(cfg.env.name), str(cfg.get("run_name") or cfg.method.name), int(cfg.seed)),
        group=str(cfg.study),
        job_type=str(cfg.method.name),
        run_config=config,
        _convert_="all",
        _recursive_=False,
    )


def fit_settings(fit_cfg: DictConfig) -> FitSettings:
    return FitSettings(**OmegaConf.to_container(fit_cfg, resolve=True))  # type: ignore[arg-type]


def run_status(run_dir: Path) -> str:
    """``new``, ``resumable`` (has a checkpoint) or ``finished`` (has ``summary.json``)."""
    if (run_dir / "summary.json").exists():
        return "finished"
    if latest_checkpoint(run_dir) is not None:
        return "resumable"
    return "new"


def _plot_hook(env: EnvBase) -> LoopHook:
    """The end-of-run figures; matplotlib is imported only by runs that draw them (0.5 s of a start-up)."""
    from dpiil_rl.hooks.plots import PlotHook

    return PlotHook(env)


def build_trainer(cfg: DictConfig, run_dir: str | Path) -> InteractiveTrainer:
    """Assemble the whole loop for ``cfg`` in ``run_dir``, resuming from its latest checkpoint if any."""
    run_dir = Path(run_dir)
    hold_run_dir(run_dir)
    torch.set_num_threads(int(cfg.torch_threads))
    torch.manual_seed(int(cfg.seed))
    protocol = cfg.protocol
    status = run_status(run_dir)
    run_files = RunFiles(run_dir)
    if status == "new":
        run_files.start_fresh()
        shutil.rmtree(run_dir / "checkpoints", ignore_errors=True)
    env = build_env(cfg.env, protocol.interactive_envs, seed=int(cfg.seed))
    eval_env = build_env(cfg.env, min(protocol.eval_envs, protocol.eval_episodes), seed=int(cfg.seed) + EVAL_SEED)
    method = make_method(cfg.method, cfg.get("chi"), protocol.get("chi_quantile"))
    expert = make_expert(cfg.expert, env, seed=int(cfg.seed) + EXPERT_SEED)
    actor = make_actor(cfg.modules.actor, env)
    speed_head = make_speed_head(cfg.modules.speed_head, env)
    buffer = make_buffer(run_dir, cfg.buffer.capacity)
    experience = (
        make_buffer(run_dir, cfg.buffer.experience_capacity, "experience", "buffer.experience_capacity")
        if method.needs_experience
        else None
    )
    collector = InterventionCollector(
        env, policy=actor, expert=expert, replay_buffer=buffer, experience_buffer=experience, keep_paths=True
    )
    trainer = InteractiveTrainer(
        run_dir=run_dir,
        collector=collector,
        actor=actor,
        speed_head=speed_head,
        method=method,
        buffer=buffer,
        experience=experience,
        run_files=run_files,
        logger=make_logger(cfg.logger, run_dir, cfg),
        iterations=protocol.iterations,
        demo_episodes=protocol.demo_episodes,
        expert_pairs_per_iteration=protocol.expert_pairs_per_iteration,
        max_episodes_per_iteration=protocol.max_episodes_per_iteration,
        generator=torch.Generator().manual_seed(int(cfg.seed) + TRAIN_SEED),
        progress=bool(cfg.progress),
        info={
            "env": str(cfg.env.name),
            "method": str(cfg.method.name),
            "seed": int(cfg.seed),
            "study": str(cfg.study),
            "run_name": str(cfg.get("run_name") or cfg.method.name),
            "chi_fixed": None if cfg.get("chi") is None else float(cfg.chi),
        },
    )
    eval_collector = InterventionCollector(eval_env, policy=actor, expert=None)
    hooks = [
        ("refit", RefitHook(fit_settings(cfg.modules.actor.fit), fit_settings(cfg.modules.speed_head.fit))),
        ("calibrate", CalibrateThresholdHook()),
        (
            "evaluate",
            EvaluateHook(
                eval_collector,
                protocol.eval_episodes,
                seed=int(cfg.seed) + EVAL_SEED,
                every=int(protocol.get("eval_every", 1)),
                final_iteration=int(protocol.iterations),
            ),
        ),
        ("log", LogMetricsHook()),
        ("checkpoint", CheckpointHook(keep=cfg.get("checkpoint_keep"))),
        *([("plots", _plot_hook(env))] if bool(cfg.get("plots", True)) else []),
        ("dashboard", DashboardHook()),
    ]
    for i, extra in enumerate(method.extra_hooks()):  # after the policy refit, before χ is calibrated
        hooks.insert(1 + i, (type(extra).__name__, extra))
    for name, hook in hooks:
        hook.register(trainer, name)
    if status == "resumable":
        ckpt = latest_checkpoint(run_dir)
        assert ckpt is not None
        state = load_state(ckpt)
        made = {k: state.get("info", {}).get(k) for k in ("env", "method", "seed")}
        asked = {k: trainer.info[k] for k in made}
        if any(made[k] is not None and made[k] != asked[k] for k in made):
            raise ValueError(
                f"run_dir = {str(run_dir)!r}: its checkpoint was made by "
                f"{', '.join(f'{k} {made[k]}' for k in made)}; this command asks for "
                f"{', '.join(f'{k} {asked[k]}' for k in asked)}. Expected the same to resume: pass "
                "overwrite=true to start this run over, or give it another run_name / hydra.run.dir"
            )
        trainer.load_state_dict(state, ckpt)
    return trainer

"""Write the replayed session of `expert=ur5e_sim` from the task's scripted expert (data/teleop/<env>_*.csv).

dpiil-record-session env=shaft hydra.run.dir=. hydra.output_subdir=null hydra/job_logging=stdout
"""

from __future__ import annotations

from pathlib import Path

import hydra
from omegaconf import DictConfig

from dpiil_rl.envs.factory import make_env
from dpiil_rl.experts.session_recording import record_scripted_session
from dpiil_rl.utils.cli import report_user_errors


@hydra.main(config_path="../configs", config_name="config", version_base=None)
@report_user_errors
def run(cfg: DictConfig) -> None:
    env_cfg = cfg.env.copy()
    env_cfg.start.noise = 0.0  # the recorded person starts from the nominal start
    env = make_env(env_cfg, num_envs=1, seed=int(cfg.seed))
    try:
        hand, buttons, success = record_scripted_session(
            env, Path("data/teleop"), str(cfg.env.name), seed=int(cfg.seed)
        )
    finally:
        env.close()
    print(f"[dpiil_rl] wrote {hand} and {buttons} (scripted episode {'succeeded' if success else 'FAILED'})")


def main() -> None:
    """The ``dpiil-record-session`` command."""
    run()


if __name__ == "__main__":
    main()

"""``hydra/launcher=lockstep``: the seeds of each setting batched in one process; see
:mod:`dpiil_rl.training.lockstep_launcher`."""

from dpiil_rl.training.lockstep_launcher import LockstepLauncher as _Launcher


class LockstepLauncher(_Launcher):
    """Registered with Hydra under the ``hydra_plugins`` package; everything else lives in dpiil_rl."""

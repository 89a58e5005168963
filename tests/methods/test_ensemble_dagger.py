import torch
from tensordict import TensorDict

from dpiil_rl.methods.ensemble_dagger import EnsembleDAgger
from dpiil_rl.modules.threshold import QuantileThreshold


def test_risk_is_the_ensemble_variance_alone():
    td = TensorDict(
        {
            "action_var": torch.tensor([[1e-4], [3e-3]]),
            "speed_mu": torch.tensor([[1e-3], [1.0]]),
            "speed_sigma": torch.tensor([[1e-3], [1.0]]),
        },
        batch_size=[2],
    )
    method = EnsembleDAgger("ensemble_dagger", threshold=QuantileThreshold(0.8))
    assert torch.equal(method.risk(td), td["action_var"])  # precision plays no part


def test_gate_flags_the_most_uncertain_fifth_of_the_training_data():
    var = torch.rand(2000, 1, generator=torch.Generator().manual_seed(0))
    gate = EnsembleDAgger("ensemble_dagger", threshold=QuantileThreshold(0.8)).make_gate()
    td = TensorDict({"action_var": var}, batch_size=[2000])
    gate.calibrate(td)
    assert abs(float(gate(td)["expert_mode"].float().mean()) - 0.2) < 0.002

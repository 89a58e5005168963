"""The machine facts a run records, and the MKL setting that makes the CPU kernels the same on every CPU."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest
import torch

from dpiil_rl.utils.machine import KERNEL_VARIABLES, machine_facts

#: a short fit through MKL's matrix products (forward and backward) that prints a hash of its weights
FIT = """
import hashlib, torch
g = torch.Generator().manual_seed(0)
x, y = torch.randn(512, 300, generator=g), torch.randn(512, 7, generator=g)
torch.manual_seed(0)
net = torch.nn.Sequential(torch.nn.Linear(300, 256), torch.nn.ReLU(), torch.nn.Linear(256, 7))
opt = torch.optim.Adam(net.parameters(), 1e-3)
for _ in range(20):
    opt.zero_grad()
    ((net(x) - y) ** 2).mean().backward()
    opt.step()
print(hashlib.sha256(torch.cat([p.detach().flatten() for p in net.parameters()]).numpy().tobytes()).hexdigest())
"""


def _fit_hash(**variables: str) -> str:
    env = {k: v for k, v in os.environ.items() if k not in KERNEL_VARIABLES} | variables
    done = subprocess.run([sys.executable, "-c", FIT], env=env, capture_output=True, text=True, check=True)
    return done.stdout.strip()


def test_machine_facts_name_the_cpu_code_path(monkeypatch):
    monkeypatch.setenv("MKL_CBWR", "AVX2,STRICT")
    monkeypatch.delenv("MKL_ENABLE_INSTRUCTIONS", raising=False)
    facts = machine_facts()
    assert facts["cpu"] and facts["cores"] >= 1
    assert facts["torch_cpu_capability"] == torch.backends.cpu.get_cpu_capability()
    assert facts["torch"] == torch.__version__
    assert facts["kernel_variables"] == {"MKL_CBWR": "AVX2,STRICT"} | (
        {k: os.environ[k] for k in ("ATEN_CPU_CAPABILITY", "ONEDNN_MAX_CPU_ISA") if k in os.environ}
    )


def test_mkl_cbwr_makes_a_fit_independent_of_the_instruction_set():
    """With ``MKL_CBWR=AVX2,STRICT`` a fit gives the same bits whether MKL may use every instruction set of
    this CPU or only AVX2 (what an older CPU has): the setting docs/usage.md gives for runs that must
    reproduce byte for byte on another machine."""
    if "AVX" not in torch.backends.cpu.get_cpu_capability():
        pytest.skip("not an x86 CPU with AVX: MKL's AVX2 code path does not exist here")
    strict = _fit_hash(MKL_CBWR="AVX2,STRICT")
    assert len(strict) == 64
    assert _fit_hash(MKL_CBWR="AVX2,STRICT", MKL_ENABLE_INSTRUCTIONS="AVX2") == strict

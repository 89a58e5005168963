"""The facts about the machine that a run's numbers depend on, recorded in ``summary.json`` as ``machine``.

A run is a deterministic function of its config on one machine: trained again there it gives its records
byte for byte. Across machines it is not, because MKL (torch's CPU matrix library) picks its kernels by the
CPU's instruction set (AVX2, AVX-512, ...), and their sums round differently; a fit that differs in the
seventh digit sends a learning run down another path. ``MKL_CBWR`` (MKL's conditional numerical
reproducibility, e.g. ``MKL_CBWR=AVX2,STRICT``, set before the run starts) makes MKL take the same code
path on every CPU that has it, at a cost in fit time (docs/usage.md, "Reproducing a run on another machine").
These facts say which case a run's records are in.
"""

from __future__ import annotations

import os
import platform
from pathlib import Path
from typing import Any

import torch

#: environment variables that change the CPU kernels torch and MKL use
KERNEL_VARIABLES = ("MKL_CBWR", "MKL_ENABLE_INSTRUCTIONS", "ATEN_CPU_CAPABILITY", "ONEDNN_MAX_CPU_ISA")


def cpu_model() -> str:
    """The CPU's model name (Linux: ``/proc/cpuinfo``; elsewhere what ``platform`` knows)."""
    cpuinfo = Path("/proc/cpuinfo")
    if cpuinfo.is_file():
        for line in cpuinfo.read_text(errors="replace").splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    return platform.processor() or platform.machine()


def machine_facts() -> dict[str, Any]:
    """CPU model, torch's CPU capability, core count, versions and the kernel-choosing variables that are set."""
    return {
        "cpu": cpu_model(),
        "torch_cpu_capability": torch.backends.cpu.get_cpu_capability(),
        "cores": os.cpu_count(),
        "system": f"{platform.system()} {platform.machine()}",
        "python": platform.python_version(),
        "torch": torch.__version__,
        "kernel_variables": {k: os.environ[k] for k in KERNEL_VARIABLES if k in os.environ},
    }

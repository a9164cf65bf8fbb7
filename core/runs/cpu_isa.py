"""Portable runs: pin the instruction set of a run's CPU kernels (``run.cpu_isa``).

PyTorch's ATen, MKL, oneDNN, NumPy's own SIMD loops and its OpenBLAS each pick kernels by the CPU they find,
and kernels of different instruction sets round differently. A run is exact on one machine, but on another
machine the first episode's return differs in the 4th-5th significant digit and RL's dynamics amplify it, so
without a pin, reproduction across machines is statistical (docs/experiments.md, "Portable runs").

``run.cpu_isa`` (``native``: whatever the CPU offers, the default and the behaviour of every archived run;
``avx2``: x86-64-v3 kernels; ``sse42``: x86-64-v2 kernels, ATen's ``default``) names a set of environment
variables (:func:`pinned_environment`) that must be in a process's environment before torch and NumPy load
their kernels. So the pin acts where a run's process starts: ``dualsys train`` re-executes itself with the
variables (:func:`ensure_process`), ``dualsys experiment run`` starts its worker processes (and Ray tasks)
with them, and the trainer checks, before it touches the run directory, that the process it runs in is
pinned (:func:`check_process`; a pinned run never silently runs unpinned) and records the kernels it got
in ``summary.json`` (``cpu_isa``, ``cpu_capability``, ``cpu_model``).

A machine that lacks the instruction set is refused with one line (:func:`check_host`), as is a machine
that is not x86-64.
"""

from __future__ import annotations

import os
import platform
import sys
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from core.config import ConfigError

NATIVE = "native"
CPU_ISAS: tuple[str, ...] = ("native", "avx2", "sse42")
"""The values of ``run.cpu_isa``."""

CPU_ISA_KEYS: tuple[str, ...] = (
    "ATEN_CPU_CAPABILITY",
    "MKL_CBWR",
    "MKL_ENABLE_INSTRUCTIONS",
    "ONEDNN_MAX_CPU_ISA",
    "DNNL_MAX_CPU_ISA",
    "OPENBLAS_CORETYPE",
    "NPY_DISABLE_CPU_FEATURES",
)
"""Every variable a pin may set."""


@dataclass(frozen=True)
class IsaPin:
    """One pinnable instruction set: the CPU flags it needs and each library's name for it."""

    name: str
    level: str
    """The x86-64 micro-architecture level, for messages."""
    flags: tuple[str, ...]
    """``/proc/cpuinfo`` flags the host must have."""
    aten: str
    """``ATEN_CPU_CAPABILITY`` (PyTorch's vectorised ATen kernels, SLEEF included)."""
    torch_capability: str
    """What ``torch.backends.cpu.get_cpu_capability()`` then reports."""
    mkl: str
    """``MKL_CBWR`` (MKL's conditional numerical reproducibility) and ``MKL_ENABLE_INSTRUCTIONS``."""
    onednn: str
    """``ONEDNN_MAX_CPU_ISA`` (and its older name ``DNNL_MAX_CPU_ISA``)."""
    openblas: str
    """``OPENBLAS_CORETYPE`` (NumPy's OpenBLAS)."""
    numpy_allowed: frozenset[str]
    """NumPy dispatch targets that may stay enabled; the others go in ``NPY_DISABLE_CPU_FEATURES``."""


_V2 = frozenset({"SSE", "SSE2", "SSE3", "SSSE3", "SSE41", "POPCNT", "SSE42", "X86_V2"})
_V3 = _V2 | {"AVX", "F16C", "FMA3", "AVX2", "X86_V3"}

PINS: dict[str, IsaPin] = {
    "avx2": IsaPin(
        name="avx2",
        level="x86-64-v3",
        flags=("avx", "avx2", "fma", "f16c", "bmi1", "bmi2", "abm", "movbe"),
        aten="avx2",
        torch_capability="AVX2",
        mkl="AVX2",
        onednn="AVX2",
        openblas="Haswell",
        numpy_allowed=_V3,
    ),
    "sse42": IsaPin(
        name="sse42",
        level="x86-64-v2",
        flags=("ssse3", "sse4_1", "sse4_2", "popcnt", "cx16"),
        aten="default",
        torch_capability="DEFAULT",
        mkl="SSE4_2",
        onednn="SSE41",
        openblas="Nehalem",
        numpy_allowed=_V2,
    ),
}


def _numpy_disabled(pin: IsaPin) -> str:
    """NumPy's dispatch targets above ``pin`` (space-separated), read from this installation's NumPy (its
    target names differ between releases: 2.4 dispatches X86_V3/X86_V4, older ones AVX2/AVX512_SKX...)."""
    try:
        from numpy._core._multiarray_umath import __cpu_dispatch__
    except ImportError:  # pragma: no cover - NumPy < 2
        from numpy.core._multiarray_umath import __cpu_dispatch__
    return " ".join(target for target in __cpu_dispatch__ if target not in pin.numpy_allowed)


def pinned_environment(cpu_isa: str) -> dict[str, str]:
    """The variables that pin ``cpu_isa`` (``native``: none)."""
    if cpu_isa == NATIVE:
        return {}
    pin = _pin(cpu_isa)
    values = {
        "ATEN_CPU_CAPABILITY": pin.aten,
        "MKL_CBWR": pin.mkl,
        "MKL_ENABLE_INSTRUCTIONS": pin.mkl,
        "ONEDNN_MAX_CPU_ISA": pin.onednn,
        "DNNL_MAX_CPU_ISA": pin.onednn,
        "OPENBLAS_CORETYPE": pin.openblas,
    }
    disabled = _numpy_disabled(pin)
    if disabled:
        values["NPY_DISABLE_CPU_FEATURES"] = disabled
    return values


def _pin(cpu_isa: str) -> IsaPin:
    if cpu_isa not in PINS:
        raise ConfigError(f"bad value for run.cpu_isa: {cpu_isa!r} (expected one of {', '.join(CPU_ISAS)})")
    return PINS[cpu_isa]


def _cpuinfo_field(key: str, cpuinfo: str | None = None) -> str | None:
    """The value of ``/proc/cpuinfo``'s first ``key`` line (or of ``cpuinfo``'s); None where there is none."""
    if cpuinfo is None:
        try:
            cpuinfo = Path("/proc/cpuinfo").read_text()
        except OSError:
            return None
    for line in cpuinfo.splitlines():
        name, sep, value = line.partition(":")
        if sep and name.strip() == key:
            return value.strip()
    return None


def cpu_flags(cpuinfo: str | None = None) -> set[str]:
    """The host's CPU flags (``/proc/cpuinfo``'s first ``flags`` line; empty where there is none)."""
    return set((_cpuinfo_field("flags", cpuinfo) or "").split())


def cpu_vendor() -> str:
    """``intel``, ``amd`` or ``other``: the host's CPU vendor (``/proc/cpuinfo``'s vendor_id). A pinned
    instruction set makes runs identical across machines of one vendor, not across vendors: under the same
    AVX2 pin a SAC run made on an AMD EPYC and rerun on an Intel Xeon differed from its first critic value on
    (8th digit; which library rounds differently is not yet found), so bit-for-bit references are kept per
    vendor."""
    vendor = _cpuinfo_field("vendor_id")
    return {"GenuineIntel": "intel", "AuthenticAMD": "amd"}.get(vendor or "", "other")


def cpu_model() -> str:
    """The host CPU's model name (``/proc/cpuinfo``), or the platform's processor string."""
    return _cpuinfo_field("model name") or platform.processor() or platform.machine()


def missing_flags(
    cpu_isa: str, flags: set[str] | None = None, machine: str | None = None
) -> list[str] | None:
    """The flags ``cpu_isa`` needs that the host lacks (empty: it can run it); None: not an x86-64 host."""
    if cpu_isa == NATIVE:
        return []
    pin = _pin(cpu_isa)
    if (machine or platform.machine()).lower() not in ("x86_64", "amd64"):
        return None
    have = cpu_flags() if flags is None else flags
    return [flag for flag in pin.flags if flag not in have]


def host_problem(cpu_isa: str) -> str | None:
    """Why this host cannot run ``cpu_isa`` (one line), or None."""
    missing = missing_flags(cpu_isa)
    if missing is None:
        return f"run.cpu_isa={cpu_isa} pins x86-64 kernels; this machine is {platform.machine()}"
    if missing:
        pin = PINS[cpu_isa]
        return (
            f"run.cpu_isa={cpu_isa} needs a {pin.level} CPU; this one ({cpu_model()}) lacks "
            f"{', '.join(missing)} (use run.cpu_isa=native, or a pin it has)"
        )
    return None


def check_host(cpu_isa: str) -> None:
    """Raise ConfigError (one line) if this host cannot run ``cpu_isa``."""
    problem = host_problem(cpu_isa)
    if problem is not None:
        raise ConfigError(problem)


def environment_pinned(cpu_isa: str, environ: Mapping[str, str] | None = None) -> bool:
    """``environ`` (default: this process's) holds every variable of ``cpu_isa``."""
    environ = os.environ if environ is None else environ
    return all(environ.get(key) == value for key, value in pinned_environment(cpu_isa).items())


def child_environment(cpu_isa: str, base: Mapping[str, str] | None = None) -> dict[str, str]:
    """``base`` (default: this process's environment) with ``cpu_isa``'s variables set."""
    return {**(os.environ if base is None else base), **pinned_environment(cpu_isa)}


def check_process(cpu_isa: str) -> dict[str, str]:
    """Check that this process runs ``cpu_isa``'s kernels; what a run's summary records of them.

    A pinned run in a process started without its variables (torch and NumPy already chose their kernels)
    raises ConfigError, so a pin is never silently lost.
    """
    import torch

    capability = torch.backends.cpu.get_cpu_capability()
    record = {"cpu_isa": cpu_isa, "cpu_capability": capability, "cpu_model": cpu_model()}
    if cpu_isa == NATIVE:
        return record
    check_host(cpu_isa)
    pin = PINS[cpu_isa]
    unset = [key for key, value in pinned_environment(cpu_isa).items() if os.environ.get(key) != value]
    if unset:
        raise ConfigError(
            f"run.cpu_isa={cpu_isa} must be set before torch and NumPy start: this process lacks "
            f"{', '.join(unset)} (run it through `dualsys train` or `dualsys experiment run`, or start the "
            "process with core.runs.cpu_isa.child_environment)"
        )
    try:
        from numpy._core._multiarray_umath import __cpu_features__
    except ImportError:  # pragma: no cover - NumPy < 2
        from numpy.core._multiarray_umath import __cpu_features__
    above = [name for name in _numpy_disabled(pin).split() if __cpu_features__.get(name)]
    if capability != pin.torch_capability or above:
        raise ConfigError(
            f"run.cpu_isa={cpu_isa}: torch runs {capability} kernels"
            + (f" and NumPy dispatches {', '.join(above)}" if above else "")
            + f", not {pin.torch_capability}"
        )
    return record


def ensure_process(cpu_isa: str, argv: list[str] | None = None) -> None:
    """Make the ``dualsys`` command's process run ``cpu_isa``'s kernels: nothing for ``native`` or a process
    already pinned; else, after :func:`check_host`, re-execute the command (``python -m dualsys_cli.main``
    with the same arguments) with the variables set. Only a process that is the ``dualsys`` command
    re-executes; anywhere else (the CLI called in-process) it raises ConfigError."""
    if cpu_isa == NATIVE:
        return
    check_host(cpu_isa)
    if environment_pinned(cpu_isa):
        return
    argv = sys.argv if argv is None else argv
    program = Path(argv[0]) if argv else Path()
    if not (program.name == "dualsys" or program.parts[-2:] == ("dualsys_cli", "main.py")):
        raise ConfigError(
            f"run.cpu_isa={cpu_isa} must be set before torch and NumPy start; run the `dualsys` command, or "
            "start this process with core.runs.cpu_isa.child_environment"
        )
    sys.stdout.flush()
    sys.stderr.flush()
    os.execve(
        sys.executable,
        [sys.executable, "-m", "dualsys_cli.main", *argv[1:]],
        child_environment(cpu_isa),
    )

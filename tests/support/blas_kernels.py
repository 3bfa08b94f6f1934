"""The OpenBLAS kernels (``OPENBLAS_CORETYPE``) this CPU can run, for the tests and
``.ci/run`` that check results and examples are the same under each (docs/design.md,
"The same answer on every machine"). ``python tests/support/blas_kernels.py`` prints
them, one per line; a kernel whose instructions the CPU lacks is left out and named on
stderr."""
from __future__ import annotations

import sys

#: kernel -> the /proc/cpuinfo flags it needs (OpenBLAS's dynamic-arch targets)
KERNELS = {"Haswell": {"avx2", "fma"}, "SkylakeX": {"avx512f", "avx512bw", "avx512vl"},
           "Sandybridge": {"avx"}, "Prescott": {"sse3"}}


def cpu_flags() -> set[str]:
    """The CPU's feature flags (Linux); empty elsewhere."""
    try:
        with open("/proc/cpuinfo", encoding="ascii", errors="replace") as f:
            for line in f:
                if line.startswith("flags"):
                    flags = set(line.split(":", 1)[1].split())
                    return flags | ({"sse3"} if "pni" in flags else set())
    except OSError:
        pass
    return set()


def supported() -> tuple[list[str], list[str]]:
    """(kernels this CPU runs, kernels it lacks), in KERNELS order."""
    flags = cpu_flags()
    ok = [k for k, need in KERNELS.items() if need <= flags]
    return ok, [k for k in KERNELS if k not in ok]


if __name__ == "__main__":
    ok, lacking = supported()
    print("\n".join(ok))
    if lacking:
        print(f"this CPU lacks the instructions of: {', '.join(lacking)} (not checked)",
              file=sys.stderr)

"""Execution backends. A backend turns the model's jitable physics functions into compiled
loops (one generic neighbour loop, one per-particle map) and owns memory and sorting; beside
them what every backend uses: the particle sets (``particles``), the cell grid (``grid``),
Numba's thread layer (``threads``) and its on-disk cache (``numba_cache``)."""


def get_backend(name):
    if name == "cpu":
        from .cpu import CpuBackend

        return CpuBackend()
    if name == "cuda":
        from ..errors import CaseError

        try:
            from numba import cuda

            usable = cuda.is_available()
        except Exception:  # numba-cuda missing or its driver bindings broken
            usable = False
        if not usable:
            raise CaseError("backend: cuda: no usable NVIDIA GPU (numba-cuda and an NVIDIA driver are needed: "
                            "pip install -e \".[cuda]\"); use --backend cpu")
        from .cuda import CudaBackend

        return CudaBackend()
    raise ValueError(f"unknown backend {name!r}; choose 'cpu' or 'cuda'")

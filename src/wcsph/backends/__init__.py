"""Execution backends. A backend turns the model's jitable physics functions into compiled
loops (one generic neighbour loop, one per-particle map) and owns memory and sorting."""


def get_backend(name):
    if name == "cpu":
        from .cpu import CpuBackend

        return CpuBackend()
    if name == "cuda":
        from .cuda import CudaBackend

        return CudaBackend()
    raise ValueError(f"unknown backend {name!r}; choose 'cpu' or 'cuda'")

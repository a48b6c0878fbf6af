"""Models: declarations of which physics terms each interaction pass uses."""


def get_model(name):
    if name == "classic":
        from .classic import ClassicWCSPH

        return ClassicWCSPH
    if name == "bi":
        from .bi import WCSPHBI

        return WCSPHBI
    raise ValueError(f"unknown model {name!r}")

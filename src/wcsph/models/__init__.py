"""Models: declarations of which physics terms each interaction pass uses."""


def get_model(name):
    if name == "classic":
        from .classic import ClassicWCSPH

        return ClassicWCSPH
    raise ValueError(f"unknown model {name!r}")

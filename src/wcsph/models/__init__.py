"""The model: one class composed from the plug-in slots; ``model.name`` picks the defaults."""


def get_model(name):
    from .wcsph import WCSPH

    return WCSPH

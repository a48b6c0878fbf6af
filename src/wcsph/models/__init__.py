"""The model: one class (``wcsph.WCSPH``) composed from the plug-in slots; ``model.name`` only
picks the defaults of the slots (``slots.PRESETS``)."""

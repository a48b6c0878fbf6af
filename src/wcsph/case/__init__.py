"""A case as data: the TOML file or dict read and validated with errors naming the key
(``config``), and the particles, walls and bodies it describes placed (``geometry``)."""

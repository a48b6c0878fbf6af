"""Input and output: geometry files (``readers``), formulas in a case (``expressions``),
VTK files (``vtk``), probes, grids, the free surface and plots; one point sampler
(``sampling``) for all that read the fluid at a point."""

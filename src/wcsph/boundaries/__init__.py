"""What a case's boundaries do over time: prescribed wall motion and wavemakers (``motion``),
floating rigid bodies moved by the fluid (``floating``), inflow and outflow buffers
(``open_boundary``)."""

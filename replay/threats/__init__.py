"""Pop-up threats: their kinds (:mod:`replay.threats.kinds`), the superellipsoid body, the
vectorised table the loop judges separations with, the threat file format, hill clusters."""

"""What the aircraft senses threats with: the radar, the rangefinders (ray casting), the
cooperative (ADS-B-like) sensor, behind one protocol with their shared helpers (:mod:`replay.sensors.base`)."""

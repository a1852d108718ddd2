"""What a replay records and how it is read back: the run recorder (:mod:`replay.record.recorder`),
the MCAP writer, topics, message schemas and encoders, the 3D scene, the reader, the run picture
and the Foxglove layout."""

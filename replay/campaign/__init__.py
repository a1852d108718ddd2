"""Monte Carlo campaigns (``terrapath campaign``): a spec (:mod:`.spec`), the seeds' threat
generators (:mod:`.generators`), the runner and its executors (:mod:`.runner`) and the SQLite store
(:mod:`.store`)."""

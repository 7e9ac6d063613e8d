"""Choosing the measurement configurations: the plan (:mod:`.plan`), what the workcell allows
(:mod:`.constraints`, :mod:`.feasibility`), the search objectives (:mod:`.objectives`), the search
methods (:mod:`.exchange`, :mod:`.continuous`, run by :mod:`.multistart`) and the driver
:func:`~pincal.planning.driver.design`."""

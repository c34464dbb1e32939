"""Running compiled code: simulate, ensemble, events and dense output, Taylor and its lanes, the atlas, the fast path, error estimates, extremes, the precision ladder."""

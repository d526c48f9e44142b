"""Online evaluation of a policy in tasks (paper A.4, A.6): the 30 Hz / 10 Hz episode loop
(:mod:`.evaluate`), many episodes with resume, workers and dead-server handling (:mod:`.runner`),
frozen suites (:mod:`.suites`), results on disk (:mod:`.results`), Wilson intervals and paired
tests (:mod:`.significance`), and ``pipette eval report`` (:mod:`.report`)."""

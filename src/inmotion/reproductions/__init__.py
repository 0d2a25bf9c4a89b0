"""inmotion.reproductions: the experiments that reproduce each paper, above the library.

One module per paper (:mod:`.paper000` ... :mod:`.paper004`) and one for the real logs
(:mod:`.real`, with :mod:`.psins`); :mod:`.suite` lists them (``inmotion reproduce``), runs them
and recounts the verdicts, :mod:`.page` writes the HTML page, :mod:`.common` holds their shared
Monte Carlo loop. This package imports the methods, the simulator and :mod:`inmotion.evaluate`;
nothing in the library imports it (a test checks), and nothing in the library exists only for it.
"""

"""The HTML pages a run writes: :mod:`.index` (``index.html``, the run's page, led by the
design) and :mod:`.design` (``design.html``, drag-to-design, with its browser port
``design.js``). Text and markup only: no matplotlib, so a run without figures does not load it.
"""

"""HTTP routes: :mod:`.tables` (the API) and :mod:`.pages` (the HTML page)."""

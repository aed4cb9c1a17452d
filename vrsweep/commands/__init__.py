"""One module per CLI command (after rasterio's ``rio``); shared options live in options.py."""

"""Renders spread over a Dask cluster (the optional `dask` extra), or done here.

units.py is what a worker runs and knows nothing of Dask; cluster.py is the only module
that imports it, and only when --workers or --scheduler asks for a cluster. batch.py
submits the units of a batch, writes each result as it arrives, and resumes; tiles.py
assembles one image from bands of rows; sweep.py turns `--set c=1..12` into jobs.
"""

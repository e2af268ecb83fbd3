"""The OpenCL C sources, installed as ``ugpcl.clkernels``: one ``<stem>.cl`` per chapter and ``include/*.h`` shared
by several. No Python lives here; ``ugpcl.runtime`` finds the files through ``importlib.resources``."""

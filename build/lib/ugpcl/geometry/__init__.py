"""CPU-side geometry: mesh exporters and other algorithms that run on the host."""

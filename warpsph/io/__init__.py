"""Output layer: HDF5 results + XDMF index, USD particle cache, restart checkpoints (docs/output.md).

Pure numpy/h5py; ``pxr`` (usd-core) is imported only when a UsdParticleCache is created.
"""

from .checkpoint import Checkpoint, load_checkpoint, save_checkpoint
from .results import FORMAT_VERSION, Results, ResultsWriter, load_results
from .usd import UsdParticleCache
from .xdmf import XdmfIndex, write_xdmf

__all__ = [
    "FORMAT_VERSION",
    "Checkpoint",
    "Results",
    "ResultsWriter",
    "UsdParticleCache",
    "XdmfIndex",
    "load_checkpoint",
    "load_results",
    "save_checkpoint",
    "write_xdmf",
]

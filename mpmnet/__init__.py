"""MPMNet: a learned warm start for the IQ-MPM pressure solve (see mpmnet/README.md).

The solver writes ``pressure_fields.h5`` per run; this package turns those files into
training windows (``data``), groups runs into train / validation / test splits by scene and
resolution (``splits``), defines the network and the TorchScript module the solver loads
(``model``), trains it (``train``) and measures it offline (``evaluate``).
"""

import os

# OpenMP threads that spin while waiting for work collapse on a shared machine: with two
# torch threads on two cores busy with a compiler, training ran 15x slower than with
# passive waiting (1.5 against 23 windows/s). The variable is read when the OpenMP runtime
# starts, so this works when mpmnet is imported before torch (the CLIs do).
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

__version__ = "1"

#: The contract version of the dataset file, the split file and the model file.
FORMAT_VERSION = 1


class MPMNetError(Exception):
    """Bad input (a file of the wrong format, an inconsistent split): the CLIs exit 2."""

"""``python -m proofs.cli``: the ``fperr`` command."""
import sys

from . import main

sys.exit(main())

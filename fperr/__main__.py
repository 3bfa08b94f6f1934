"""``python -m fperr``: the ``fperr`` command (same as the installed console script).

The one upward import of this package: ``fperr`` is the bottom layer and never imports
``predicates`` or ``proofs``, but this file is the program's entry point, not part of the
library — nothing imports it, and the command-line module it starts (``proofs.cli``, the
top layer) is imported only when ``python -m fperr`` runs it.
"""
if __name__ == "__main__":
    import sys

    from proofs.cli import main

    sys.exit(main())

"""Pictures of registrations (matplotlib) and ``fperr demo``, the built-in examples."""

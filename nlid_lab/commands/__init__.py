"""CLI sub-commands: each module defines ``register(subparsers)``; found automatically."""

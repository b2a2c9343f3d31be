"""CLI sub-commands: each module defines ``register(subparsers)``; found automatically.

`nlid_lab.cli` imports every module here to build the parser, so a command imports its work
(numerics, store, figures) inside ``run``: only the command that runs pays for it.
"""

"""physval's commands, one module each (the module's name is the command's, with `_` for
`-`). Every module has the same two public names: `add_parser(subparsers)` adds the
command's parser, `run(args) -> int` does the work and returns the exit code.
physval.cli dispatches to them; options.py holds what they share.
"""

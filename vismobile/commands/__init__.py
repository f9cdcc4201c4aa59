"""CLI commands, one module each: add_parser(subparsers) -> parser, run(args) -> exit code."""

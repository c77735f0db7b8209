"""``inclino``: the command line, one module per subcommand, on the node's pipeline and core."""

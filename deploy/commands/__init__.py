"""The ``lunarsim`` commands that start and ship things: ``run``, ``batch``, ``collect-batch``, ``router``,
``scenario``, ``command``, ``check-behaviour``, ``acl``. One module a command (``deploy.cli`` finds them by name):
``add_arguments(parser)``, then ``run(args)`` checks the arguments and calls the library module that does the work."""

"""Command-line front end of depixel (installed as the ``depixel_cli`` package).

It parses options, builds a :class:`depixel.Params`, calls the library and maps library
errors to exit codes; it holds no algorithm.
"""

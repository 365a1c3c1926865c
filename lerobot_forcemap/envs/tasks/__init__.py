"""Tasks: one module per task, each a ``ForceTask`` subclass plus its gym env class (see ``base.py``).

Modules are imported by gym's entry points (``registration.py``), not here, so that importing the
package stays cheap.
"""

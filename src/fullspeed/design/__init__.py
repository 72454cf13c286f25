"""Everything formed from a machine before a run: the design rules with their
reasons (rules), the machine and the scenario designed (machine, scenario),
the controller's model of the machine (controller), what a flux map gives the
design (magnetics), the load-time checks (checks, xcomp) and what `fullspeed
design` prints (report)."""

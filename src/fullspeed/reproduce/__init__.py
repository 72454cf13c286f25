"""`fullspeed reproduce`: the claims (claims), the registry the papers'
measurements fill (registry), the papers (papers/*, which import the
registry and nothing above them) and the report that runs them (report)."""

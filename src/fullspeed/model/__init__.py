"""The data model: units, errors, files, the schema, machines and flux maps,
scenarios as validated data (loading, merging `--set`, checking fields);
nothing here designs or runs."""

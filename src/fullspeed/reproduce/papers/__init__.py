"""The measurements behind the claims, one module per paper. Importing this
package registers them in reproduce.registry.MEASURES."""
from . import beyond, fmu, pil, real, start, yang2022, yu2022, zoo, zou2021  # noqa: F401

"""USD asset library: generation, index, validation, USD -> MjSpec, path repair."""

# MuJoCo registers its OpenUSD schemas (MjcSiteAPI, MjcImageableAPI, ...) with pxr's plugin
# registry when it is imported. pxr reads that registry once, at its first stage: opened before
# ``import mujoco``, the schemas are unknown for the whole process and MuJoCo's USD import then
# silently drops every site. Every pxr use in Pipette is under this package, so import it here.
import mujoco  # noqa: F401  (see above)

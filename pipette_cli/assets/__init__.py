"""USD asset library: generation, index, validation, USD -> MjSpec, path repair."""

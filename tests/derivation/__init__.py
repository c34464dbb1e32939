"""The symbolic derivation: Lagrangian identities, the cache, the equations against independent references."""

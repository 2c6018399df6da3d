"""Part of the C+ compiler."""

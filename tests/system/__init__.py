"""The product as a user meets it: the CLI and its errors, the wheel, the README, the C example, fuzzing, the cache, progress lines."""

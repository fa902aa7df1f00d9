"""Pattern descriptors and families (Richard et al. §5.2.2): measure a pattern, name its kind."""

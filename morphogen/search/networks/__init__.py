"""Reaction-network evolution (Yamamoto et al. §3-4): genomes with runtime structure, the
genetic operators, the cluster-head fitness and the generation loop."""

"""Search for model parameters: strategies (GA, CMA-ES), fitness functions, run archive."""

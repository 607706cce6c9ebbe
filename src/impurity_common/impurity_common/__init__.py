"""Shared pieces of the impurity-picking cell: cell geometry, heightmap grid, names, enums, message
conversions, the node main idiom, parameters, colour, race-free action clients, weights files."""

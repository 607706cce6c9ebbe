"""Shared pieces of the impurity-picking cell: geometry constants, message conversions, node main."""

"""What RViz / Foxglove show: message builders (visualisation), cell_state_publisher, decision_markers."""

"""Online placement planning: scenes, occupancy, navigation and manipulation cost maps."""

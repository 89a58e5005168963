"""Study-level reporting: a study's runs loaded and recomputed, statistics, frontier, tables, figures, reports."""

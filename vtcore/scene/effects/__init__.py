"""Effect adapters: each module registers the effects of one vtcore package."""

"""Pattern functions and tears: analytic wrinkle, dimple and eye-pouch patterns
(functions), dripping and shedding tears (tears, mls)."""

"""Named tolerances, each with the reason for its size."""

# Algebraic identities evaluated in double precision (orthogonality, log(exp(w)) = w).
EXACT = dict(rtol=1e-12, atol=1e-12)

# Central finite differences with step h ~ 1e-6 (relative): truncation O(h^2) ~ 1e-12 and
# cancellation ~ eps / h ~ 1e-10 of the largest entry; 1e-6 of the largest entry leaves margin.
FD_TANGENT = 1e-6

# The closed-form co-rotational tip error for a cantilever under an end moment (issue 2).
CLOSED_FORM = 1e-8

# Five-digit published elastica tables (Bisshopp & Drucker 1945 / Mattiasson 1981).
TABLE_5DIG = dict(rtol=0.0, atol=5e-5)

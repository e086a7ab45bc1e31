"""``vibroimpact bench --peers`` (issue 9): the same problems through our integrators, SciPy
``solve_ivp`` with contact events, OpenSeesPy and Exudyn (optional extra ``.[peers]``),
timed in this process and checked against one converged SciPy reference per problem."""

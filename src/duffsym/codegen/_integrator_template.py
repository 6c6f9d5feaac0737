# Fixed-step RK4 with stiffness-chosen substeps. This text is appended to each generated model
# module (which defines N_STATES, N_INPUTS, rhs, jac and output), so numba compiles the model's
# functions inline and caches the machine code beside the generated file.
# It is a template, not an importable module: it refers to names the generated module defines.

STATUS_OK = 0
STATUS_BLOWUP = 1
STATUS_TOO_STIFF = 2


@njit(cache=True, inline="always")
def spectral_radius(J):
    n = J.shape[0]
    if n == 1:
        return abs(J[0, 0])
    if n == 2:
        tr = J[0, 0] + J[1, 1]
        det = J[0, 0] * J[1, 1] - J[0, 1] * J[1, 0]
        disc = 0.25 * tr * tr - det
        if disc >= 0.0:
            s = math.sqrt(disc)
            return max(abs(0.5 * tr + s), abs(0.5 * tr - s))
        return math.sqrt(det)  # complex pair: |lambda|^2 = det
    # Gershgorin bound (over-estimates, hence safe) for larger systems
    best = 0.0
    for i in range(n):
        s = 0.0
        for j in range(n):
            s += abs(J[i, j])
        best = max(best, s)
    return best


@njit(cache=True, inline="always")
def _stiffness(x, u, p, J):
    jac(x, u, p, J)
    return spectral_radius(J)


@njit(cache=True, inline="always")
def _within(x, blowup):
    """Every component finite and at most ``blowup`` in magnitude (NaN fails the test)."""
    for i in range(x.shape[0]):
        if not (abs(x[i]) <= blowup):
            return False
    return True


@njit(cache=True, fastmath=FASTMATH)
def integrate(t, U, x0, p, substeps, h_lambda, max_substeps, hold, blowup, X, Y, M):
    """Integrate from x0 over the sample times t with inputs U (n_times, n_inputs).

    substeps > 0 fixes the number of RK4 substeps per sample interval; substeps <= 0 chooses it
    from the local stiffness so that h * rho(J) <= h_lambda at both ends of the interval: the
    count is predicted from the stiffness at the start extrapolated along its trend over the
    previous interval, and the step is redone with more substeps if the end state is stiffer.
    Writes states X (n_times, n_states), outputs Y (n_times,), substeps used M (n_times - 1,).
    Returns (status, index of the first failed sample or -1).
    """
    n = x0.shape[0]
    x = np.empty(n)
    xo = np.empty(n)
    J = np.empty((n, n))
    for i in range(n):
        x[i] = x0[i]
        X[0, i] = x0[i]
    Y[0] = output(x, U[0], p)
    adaptive = substeps <= 0
    rho = 0.0
    rho_prev = -1.0
    dt_prev = 1.0
    if adaptive:
        rho = _stiffness(x, U[0], p, J)
    for k in range(t.shape[0] - 1):
        dt = t[k + 1] - t[k]
        if adaptive:
            # predicted end-of-interval stiffness: linear trend of the last interval (rising
            # stiffness, e.g. an accelerating damper, would otherwise cost a redo every step)
            r = rho
            if rho_prev >= 0.0 and rho > rho_prev:
                r = rho + (rho - rho_prev) * (dt / dt_prev)
            m = max(1, int(math.ceil(dt * r / h_lambda)))
            rho_prev = rho
            dt_prev = dt
        else:
            m = substeps
        while True:
            if m > max_substeps:
                for kk in range(k + 1, t.shape[0]):
                    Y[kk] = np.nan
                    for i in range(n):
                        X[kk, i] = np.nan
                return STATUS_TOO_STIFF, k
            _advance(x, U, k, p, dt, m, hold, xo)
            finite = _within(xo, blowup)
            if not finite:
                # in auto mode an overshooting trial step is not yet a blow-up: the stiffness
                # estimate at its start can be far too low (it grows like x'^(n-1) within the
                # step). Retry with more substeps; only a step that stays non-finite at
                # max_substeps is a blow-up of the trajectory itself.
                if adaptive and m < max_substeps:
                    m = min(max_substeps, 4 * m)
                    continue
                break
            if not adaptive:
                break
            rho = _stiffness(xo, U[k + 1], p, J)
            # accept only if the end state agrees with the substep count; an under-resolved
            # step under-estimates the stiffness (the impulsive start: a velocity input at rest),
            # so iterate to a consistent count, without slack
            if dt * rho / m <= h_lambda:
                break
            # (the end state of an under-resolved trial can be far off and ask for more than
            # max_substeps: a false "too stiff", e.g. the Dyke record's off-equilibrium start;
            # simulate(method="auto") then reruns the trajectory with the implicit ROS2 below)
            m = max(m + 1, int(math.ceil(dt * rho / h_lambda)))
        if not finite:
            for kk in range(k + 1, t.shape[0]):
                Y[kk] = np.nan
                for i in range(n):
                    X[kk, i] = np.nan
            return STATUS_BLOWUP, k + 1
        M[k] = m
        for i in range(n):
            x[i] = xo[i]
            X[k + 1, i] = xo[i]
        Y[k + 1] = output(x, U[k + 1], p)
    return STATUS_OK, -1

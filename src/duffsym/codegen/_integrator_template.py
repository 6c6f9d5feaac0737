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


@njit(cache=True, parallel=True)
def integrate_batch(t, U, X0, P, substeps, h_lambda, max_substeps, hold, blowup, Y, status, fail_index, total_substeps):
    """integrate() for many parameter sets (rows of P) and initial states (rows of X0), in parallel."""
    n_sets = P.shape[0]
    n_times = t.shape[0]
    for s in prange(n_sets):
        X = np.empty((n_times, X0.shape[1]))
        M = np.zeros(max(n_times - 1, 1), dtype=np.int64)
        st, idx = integrate(t, U, X0[s], P[s], substeps, h_lambda, max_substeps, hold, blowup, X, Y[s], M)
        status[s] = st
        fail_index[s] = idx
        total_substeps[s] = M.sum()


# ------------------------------------------------------------------------------------------------
# Linearly implicit (Rosenbrock) integrator for stiff runs: ROS2 of Verwer, Spee, Blom & Hundsdorfer
# (SIAM J. Sci. Comput. 20, 1999), gamma = 1 + 1/sqrt(2). Second order for any Jacobian (a W-method,
# so the time dependence of the input needs no df/dt term), L-stable, one LU of (I - gamma h J) per
# step and no Newton iteration. The embedded first-order solution x + h k1 gives the error estimate.

ROS_GAMMA = 1.0 + 1.0 / math.sqrt(2.0)


@njit(cache=True, inline="always")
def _lu(A, piv):
    """In-place LU factorisation with partial pivoting; False if singular."""
    n = A.shape[0]
    for c in range(n):
        r = c
        big = abs(A[c, c])
        for i in range(c + 1, n):
            if abs(A[i, c]) > big:
                big = abs(A[i, c])
                r = i
        if not (big > 0.0):
            return False
        piv[c] = r
        if r != c:
            for j in range(n):
                tmp = A[c, j]
                A[c, j] = A[r, j]
                A[r, j] = tmp
        for i in range(c + 1, n):
            f = A[i, c] / A[c, c]
            A[i, c] = f
            for j in range(c + 1, n):
                A[i, j] -= f * A[c, j]
    return True


@njit(cache=True, inline="always")
def _lu_solve(A, piv, b):
    """Solve A z = b in place (b becomes z) with the factors of _lu."""
    n = A.shape[0]
    for c in range(n):
        r = piv[c]
        if r != c:
            tmp = b[c]
            b[c] = b[r]
            b[r] = tmp
    for i in range(n):
        for j in range(i):
            b[i] -= A[i, j] * b[j]
    for i in range(n - 1, -1, -1):
        for j in range(i + 1, n):
            b[i] -= A[i, j] * b[j]
        b[i] /= A[i, i]


@njit(cache=True)
def _ros2_step(x, ua, ub, p, h, J, A, piv, k1, k2, xs, f, xn, err):
    """One ROS2 step of size h from x (input ua at the start, ub at the end). Writes xn and the
    embedded error err; False if the step matrix is singular or the stage is not finite."""
    n = x.shape[0]
    jac(x, ua, p, J)
    for i in range(n):
        for j in range(n):
            A[i, j] = -ROS_GAMMA * h * J[i, j]
        A[i, i] += 1.0
    if not _lu(A, piv):
        return False
    rhs(x, ua, p, k1)
    _lu_solve(A, piv, k1)
    for i in range(n):
        xs[i] = x[i] + h * k1[i]
    if not _within(xs, 1e300):
        return False
    rhs(xs, ub, p, f)
    for i in range(n):
        k2[i] = f[i] - 2.0 * k1[i]
    _lu_solve(A, piv, k2)
    for i in range(n):
        xn[i] = x[i] + h * (1.5 * k1[i] + 0.5 * k2[i])
        err[i] = 0.5 * h * (k1[i] + k2[i])
    return True


@njit(cache=True)
def integrate_implicit(t, U, x0, p, substeps, rtol, atol, max_steps, hold, blowup, X, Y, M):
    """Integrate with ROS2 over the sample times t (same arguments and outputs as integrate()).

    substeps > 0 takes that many equal steps per sample interval (a fixed discretisation, for
    finite differences); substeps <= 0 controls the step size by the embedded error estimate
    (scaled RMS norm with rtol, atol), carrying the step size from one interval to the next.
    Blow-up (a state non-finite or beyond ``blowup``) and step-size collapse (more than max_steps
    steps in one interval, or a step below 1e-12 of the interval) stop the run and are reported.
    M holds the accepted steps per interval.

    Long: a numba kernel; its step loop stays whole because every helper called per step costs a call
    in the innermost loop, and the step-size control shares most of the loop's local state.
    """
    n = x0.shape[0]
    ni = U.shape[1]
    x = np.empty(n)
    xn = np.empty(n)
    J = np.empty((n, n))
    A = np.empty((n, n))
    piv = np.zeros(n, dtype=np.int64)
    k1 = np.empty(n)
    k2 = np.empty(n)
    xs = np.empty(n)
    f = np.empty(n)
    err = np.empty(n)
    ua = np.empty(ni)
    ub = np.empty(ni)
    for i in range(n):
        x[i] = x0[i]
        X[0, i] = x0[i]
    Y[0] = output(x, U[0], p)
    adaptive = substeps <= 0
    h = -1.0
    for k in range(t.shape[0] - 1):
        dt = t[k + 1] - t[k]
        if h <= 0.0 or h > dt:
            h = dt
        if not adaptive:
            h = dt / substeps
        tau = 0.0
        steps = 0
        tries = 0
        start_norm = 1e-300
        for i in range(n):
            start_norm = max(start_norm, abs(x[i]))
        status = STATUS_OK
        while tau < dt * (1.0 - 1e-12):
            last = tau + h >= dt * (1.0 - 1e-12)
            hs = dt - tau if last else h
            if tries >= max_steps or hs < 1e-12 * dt:
                # a step size collapsing while the state grows tenfold within the interval is a
                # finite-time escape (blow-up); otherwise the right-hand side is too stiff/rough
                grown = 0.0
                for i in range(n):
                    grown = max(grown, abs(x[i]))
                status = STATUS_BLOWUP if grown > 10.0 * start_norm else STATUS_TOO_STIFF
                break
            for j in range(ni):
                g = 0.0 if hold else (U[k + 1, j] - U[k, j]) / dt
                ua[j] = U[k, j] + tau * g
                ub[j] = U[k, j] + (tau + hs) * g
            ok = _ros2_step(x, ua, ub, p, hs, J, A, piv, k1, k2, xs, f, xn, err)
            tries += 1
            if adaptive:
                e = 0.0
                if ok:
                    for i in range(n):
                        sc = atol + rtol * max(abs(x[i]), abs(xn[i]))
                        e += (err[i] / sc) ** 2
                    e = math.sqrt(e / n)
                if not ok or not (e == e) or e > 1.0:
                    fac = 0.2 if not ok or not (e == e) else max(0.2, 0.9 / math.sqrt(e))
                    h = hs * fac
                    continue
                fac = 5.0 if e == 0.0 else min(5.0, 0.9 / math.sqrt(e))
                if not last:
                    h = hs * fac
                else:
                    h = max(h, hs * fac) if hs < h else hs * fac
            elif not ok:
                status = STATUS_BLOWUP
                break
            if not _within(xn, blowup):
                status = STATUS_BLOWUP
                break
            for i in range(n):
                x[i] = xn[i]
            tau += hs
            steps += 1
        if status != STATUS_OK:
            for kk in range(k + 1, t.shape[0]):
                Y[kk] = np.nan
                for i in range(n):
                    X[kk, i] = np.nan
            return status, (k + 1 if status == STATUS_BLOWUP else k)
        M[k] = steps
        for i in range(n):
            X[k + 1, i] = x[i]
        Y[k + 1] = output(x, U[k + 1], p)
    return STATUS_OK, -1

# Batch RK4 on a fixed substep schedule, with a stiffness check. Appended to the model's generated
# module (duffsym.codegen.compiled.generate_source), which defines rhs, jac, output, _advance and
# _stiffness; numba compiles it inline and caches the machine code beside the file.
# A template, not an importable module.


@njit(cache=True, parallel=True)
def integrate_schedule_batch(t, U, X0, P, M, hold, blowup, hrho_max, Y, status, fail_index, worst_hrho):
    """RK4 with M[k] substeps over sample interval k (the same for every parameter set), for the
    parameter sets P (n_sets, n_params) from the initial states X0 (n_sets, n_states).

    After each interval the stiffness h*rho(J) of the end state is checked: above hrho_max the
    fixed schedule no longer resolves the dynamics and the set is stopped with status 2 (too
    stiff); a non-finite or huge state gives status 1 (blow-up). Writes Y (n_sets, n_times),
    status, fail_index (first failed sample or -1) and worst_hrho (largest h*rho seen).
    """
    n_sets = P.shape[0]
    n_times = t.shape[0]
    n = X0.shape[1]
    for s in prange(n_sets):
        x = np.empty(n)
        xo = np.empty(n)
        J = np.empty((n, n))
        p = P[s]
        for i in range(n):
            x[i] = X0[s, i]
        Y[s, 0] = output(x, U[0], p)
        st = 0
        idx = -1
        worst = (t[1] - t[0]) * _stiffness(x, U[0], p, J) / M[0]
        if not (worst <= hrho_max):
            st = 2
            idx = 0
        if st == 0:
            for k in range(n_times - 1):
                dt = t[k + 1] - t[k]
                m = M[k]
                _advance(x, U, k, p, dt, m, hold, xo)
                if not _within(xo, blowup):
                    st = 1
                    idx = k + 1
                    break
                hr = dt * _stiffness(xo, U[k + 1], p, J) / m
                if k + 1 < n_times - 1:
                    # the next interval's substeps must also resolve this state
                    hr = max(hr, (t[k + 2] - t[k + 1]) * (hr * m / dt) / M[k + 1])
                if hr > worst:
                    worst = hr
                if not (hr <= hrho_max):
                    st = 2
                    idx = k + 1
                    break
                for i in range(n):
                    x[i] = xo[i]
                Y[s, k + 1] = output(x, U[k + 1], p)
        if st != 0:
            for kk in range(max(idx, 0), n_times):
                Y[s, kk] = np.nan
        status[s] = st
        fail_index[s] = idx
        worst_hrho[s] = worst

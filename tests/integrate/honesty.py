"""The honesty check the integrator tests share: values against independent references."""


def assert_honest(v, e, refs, tol, context=()):
    """Every texel-channel of ``v`` within its reported error ``e`` of the reference value (plus
    the reference's own bound), and within ``tol`` of it. ``refs[k]``: the references of texel k,
    one per channel (``.value``, ``.err``); ``context`` goes into the failure message."""
    for k, r in enumerate(refs):
        for ch, rr in enumerate(r):
            err = abs(v[k, ch] - rr.value)
            assert err <= e[k, ch] + rr.err, (*context, k, ch, v[k, ch], rr.value, e[k, ch])
            assert err <= tol + rr.err, (*context, k, ch, v[k, ch], rr.value, tol)

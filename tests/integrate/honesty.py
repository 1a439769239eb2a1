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


def reference_set(mode, dist, shadowing, mu, alpha, eta=None, fresnel=("one",)):
    """One texel set with its references (method B of the independent reference):
    ``(mode, integrate_texels keywords, mu, alpha, eta, refs)``, refs[k] one per channel.
    ``dist``, ``shadowing`` by name; ``fresnel`` = (type, p0) for reflection ("one": F = 1)."""
    import numpy as np

    from bsdf_tab.model import DISTRIBUTIONS, SHADOWINGS
    from bsdf_tab.model.fresnel import FRESNELS
    from tests.reference import microfacet_ref as ref

    kw = {"dist": DISTRIBUTIONS[dist], "shadowing": SHADOWINGS[shadowing]}
    if fresnel[0] != "one":
        kw.update(ftype=FRESNELS[fresnel[0]], fp0=fresnel[1])
    if mode == "reflect":
        eta = np.ones(len(mu))
        refs = [(ref.albedo(m, a, dist, shadowing, fresnel, methods="B"),) for m, a in zip(mu, alpha)]
    else:
        refs = [ref.dielectric(m, a, t, dist, shadowing, methods="B") for m, a, t in zip(mu, alpha, eta)]
    return mode, kw, mu, alpha, eta, refs

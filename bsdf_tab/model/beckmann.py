"""Beckmann microfacet distribution: everything the package knows about it.

D, the exact Smith Lambda (and |cos| Lambda), visible-normal sampling, the CDF of D(m) cos(theta_m)
in theta_m and its inverse (for D cos sampling and the adaptive integrator's outer variable), and
the bound on |d ln D / d cos theta_m| the bsdf table uses to propagate rounding. Registered in
:mod:`bsdf_tab.model.distribution` under :data:`NAME`.

References: Walter et al. 2007 (D, eq. 25; Smith Lambda, eq. 27 without the rational
approximation); Heitz and d'Eon 2014, "Importance Sampling Microfacet-Based BSDFs using the
Distribution of Visible Normals" (visible-slope sampling, solved here by safeguarded Newton).
"""

from typing import Any

import warp as wp

from .frame import expm1_, log1p_
from .ierfc_table import IERFC_A_MAX, IERFC_PER_UNIT, IERFC_PIECES, IERFC_TAIL
from .lambda_b_table import LAMBDA_B_E_MIN, LAMBDA_B_MAX, LAMBDA_B_PER_OCTAVE, LAMBDA_B_PIECES

NAME = "beckmann"
DESCRIPTION = "Beckmann, alpha = alpha_b (Walter et al. 2007 eq. 25)"

_HALF_PI = 1.5707963267948966
_INV_SQRT_PI = 0.56418958354775628
_HALF_INV_SQRT_PI = 0.28209479177387814

# h(a) = exp(a^2) ierfc(a) = 1 / sqrt(pi) - a exp(a^2) erfc(a), a >= 0, as 16 polynomials of
# degree 11 (Chebyshev interpolants at 40 digits by mpmath.chebyfit, coefficients c_0 .. c_11
# of the local variable x in [-1, 1]): rows 0-11 in a on [k / 4, (k + 1) / 4], x = 8 a - (2 k + 1);
# rows 12-15 h = u P(x) in u = 1 / a^2 on [1/16, 1/9], [1/36, 1/16], [1/64, 1/36], [0, 1/64]
# (a >= 3), x = u s - o with (s, o) from _IERFC_UMAP. Interpolation error below 3.7e-17
# relative; the float64 evaluation within 3 ulp of h (tests/model/test_model_fastforms.py)
_IERFC_ROWS = (
    (0.4550368529124874, -0.09493282898175362, 0.012736576200676274, -0.0013506527840829116,
     0.00012212069387040536, -9.788720538352886e-06, 7.12271464125672e-07, -4.780313864598331e-08,
     2.9929618352960566e-09, -1.7633405430311015e-10, 9.921618309689385e-12, -5.270094617084246e-13),
    (0.30699312113477145, -0.056951549031276784, 0.006923931174620782, -0.0006734951044068215,
     5.633924155625215e-05, -4.205319723791011e-06, 2.8641215261045295e-07, -1.806683066391221e-08,
     1.0668788386364061e-09, -5.945874564044595e-11, 3.1702802841408654e-12, -1.600700615628178e-13),
    (0.21618090800190473, -0.0358234682338727, 0.003956944919288301, -0.00035365080994133666,
     2.7403691478279416e-05, -1.9065315938968118e-06, 1.216238156362038e-07, -7.215035015438137e-09,
     4.0203679637169787e-10, -2.120343010292162e-11, 1.0717814783393093e-12, -5.1454060190667655e-14),
    (0.1579169482454209, -0.0234946154716478, 0.002365181065457952, -0.00019464224738819098,
     1.3992804860830633e-05, -9.084573450318007e-07, 5.433419101871693e-08, -3.0336053015732003e-09,
     1.596106177912386e-10, -7.970423256268412e-12, 3.8215296706304253e-13, -1.7451308141647958e-14),
    (0.1190292440506359, -0.01598528505488314, 0.0014717331657394391, -0.0001117950946944779,
     7.469961213973306e-06, -4.532138590042578e-07, 2.5442858403284e-08, -1.338231182113129e-09,
     6.653611828787689e-11, -3.1481486740512656e-12, 1.4326969832286792e-13, -6.226539596811371e-15),
    (0.09215773498733389, -0.011232764830869648, 0.0009492977630484666, -6.673824846636862e-05,
     4.153200137471424e-06, -2.3586005668823988e-07, 1.244468527450926e-08, -6.173148719762175e-10,
     2.903106774998743e-11, -1.3025365404468215e-12, 5.6307232378188484e-14, -2.330374232341296e-15),
    (0.07301511833209168, -0.008120259348023498, 0.0006322947678105928, -4.125580250518292e-05,
     2.3963613894134203e-06, -1.276065941802131e-07, 6.3372289304896715e-09, -2.9683207623760854e-10,
     1.3217579171937921e-11, -5.628638106922625e-13, 2.3132516172063384e-14, -9.123442282164916e-16),
    (0.05900836136399919, -0.0060185787562091865, 0.00043340689663844714, -2.632046546601126e-05,
     1.4302256265133916e-06, -7.154498396686323e-08, 3.349458317073075e-09, -1.4833604352732322e-10,
     6.261328008691648e-12, -2.5332282685761485e-13, 9.906978466035922e-15, -3.726396901481254e-16),
    (0.048515058745865376, -0.004560170617840837, 0.0003048002654443207, -1.7277618897998006e-05,
     8.803190051523829e-07, -4.144750334285164e-08, 1.832162766714039e-09, -7.682434718726536e-11,
     3.077662629064997e-12, -1.184257902810641e-13, 4.41152045823036e-15, -1.5838453993534907e-16),
    (0.04048856456110296, -0.0035231263174584516, 0.00021933951703898973, -1.1637902629654938e-05,
     5.572854642324494e-07, -2.4743465416431395e-08, 1.034462057029494e-09, -4.112766670842108e-11,
     1.5656823050127555e-12, -5.736263337063088e-14, 2.0374816719065417e-15, -6.988450967202414e-17),
    (0.034234752864461634, -0.002769387750949177, 0.0001611306712342275, -8.024349276093631e-06,
     3.619496889136737e-07, -1.5184332049493947e-08, 6.013992395813955e-10, -2.2703884269737206e-11,
     8.2238658593435e-13, -2.872100150777345e-14, 9.737524213790173e-16, -3.1937516035339865e-17),
    (0.029281646329901864, -0.002210683535941924, 0.00012058705208030444, -5.651282354852955e-06,
     2.40650327698675e-07, -9.557158790571327e-09, 3.591965688038635e-10, -1.2895078261068369e-11,
     4.4501236549003253e-13, -1.4832046655047048e-14, 4.805131697656617e-16, -1.5084738875012344e-17),
    (0.2515648391865397, -0.007179817392627746, 0.00030570746904929523, -1.6545101848459857e-05,
     1.0566162218592154e-06, -7.634170318032493e-08, 6.075871454275302e-09, -5.230471502774609e-10,
     4.804930486241156e-11, -4.667761515660273e-12, 4.93178312924468e-13, -5.256040392353704e-14),
    (0.2648652926767206, -0.00599933334954651, 0.0002113606064846376, -9.787684042118719e-06,
     5.498637917187194e-07, -3.577550102582908e-08, 2.6160166140520404e-09, -2.1055941305502766e-10,
     1.836645361217467e-11, -1.7174347354232199e-12, 1.7670937715594403e-13, -1.856989103334536e-14),
    (0.27337568336052437, -0.002320362618964589, 3.161082915817204e-05, -5.817219056414426e-07,
     1.3303299048164935e-08, -3.5995455945660146e-10, 1.1158140088690485e-11, -3.873872567341768e-13,
     1.4812226319723522e-14, -6.158045342750174e-16, 2.7756805466101124e-17, -1.3270251130158354e-18),
    (0.27885185384874545, -0.003181726356136035, 5.9617529385194795e-05, -1.54142752779304e-06,
     5.0519291939773566e-08, -1.9957534233310847e-09, 9.191616598228757e-11, -4.819741440500925e-12,
     2.8266934125585777e-13, -1.829277794044853e-14, 1.3168899280662193e-15, -1.0089486839689111e-16),
)
_IERFC_UMAP = (
    (41.142857142857146, 3.5714285714285716),
    (57.6, 2.6),
    (164.57142857142858, 3.5714285714285716),
    (128.0, 1.0),
)
_vec12d = wp.types.vector(length=12, dtype=wp.float64)
(IERFC_0, IERFC_1, IERFC_2, IERFC_3, IERFC_4, IERFC_5, IERFC_6, IERFC_7,
 IERFC_8, IERFC_9, IERFC_10, IERFC_11, IERFC_12, IERFC_13, IERFC_14, IERFC_15) = (
    wp.constant(_vec12d(*row)) for row in _IERFC_ROWS)
_vec8d = wp.types.vector(length=8, dtype=wp.float64)
IERFC_UMAP = wp.constant(_vec8d(*[v for so in _IERFC_UMAP for v in so]))


@wp.func
def beckmann_D(cos_theta_m: Any, alpha: Any):
    """D(m) = exp(-tan^2 / alpha^2) / (pi alpha^2 cos^4), normalized: int D cos dw = 1."""
    zero = type(alpha)(0.0)
    if cos_theta_m <= zero:
        # back-facing micro-normals carry no area
        return zero
    if alpha <= zero:
        # alpha = 0 is a Dirac delta: no finite density
        return zero
    c2 = cos_theta_m * cos_theta_m
    a2 = alpha * alpha
    t2 = wp.max(zero, type(alpha)(1.0) - c2) / c2
    return wp.exp(-t2 / a2) / (type(alpha)(wp.pi) * a2 * c2 * c2)


@wp.func
def _ierfc_row(k: wp.int32):
    # the coefficients of row k (a binary search: constant vectors, no table copied per call)
    if k < 8:
        if k < 4:
            if k < 2:
                if k < 1:
                    return IERFC_0
                return IERFC_1
            if k < 3:
                return IERFC_2
            return IERFC_3
        if k < 6:
            if k < 5:
                return IERFC_4
            return IERFC_5
        if k < 7:
            return IERFC_6
        return IERFC_7
    if k < 12:
        if k < 10:
            if k < 9:
                return IERFC_8
            return IERFC_9
        if k < 11:
            return IERFC_10
        return IERFC_11
    if k < 14:
        if k < 13:
            return IERFC_12
        return IERFC_13
    if k < 15:
        return IERFC_14
    return IERFC_15


@wp.func
def _ierfc_poly(x: Any, c: Any):
    # sum of c[k] x^k, k = 0 .. 11, by Estrin's scheme (pairs, then powers x^2, x^4, x^8): a
    # dependency chain of 4 multiply-adds instead of Horner's 11
    x2 = x * x
    x4 = x2 * x2
    p0 = (type(x)(c[0]) + type(x)(c[1]) * x) + (type(x)(c[2]) + type(x)(c[3]) * x) * x2
    p1 = (type(x)(c[4]) + type(x)(c[5]) * x) + (type(x)(c[6]) + type(x)(c[7]) * x) * x2
    p2 = (type(x)(c[8]) + type(x)(c[9]) * x) + (type(x)(c[10]) + type(x)(c[11]) * x) * x2
    return p0 + (p1 + p2 * x4) * x4


@wp.func
def beckmann_ierfc_scaled(a: Any):
    """h(a) = exp(a^2) ierfc(a) = 1 / sqrt(pi) - a exp(a^2) erfc(a) for a >= 0 (0 at a = inf).

    ierfc(a) = int_a^inf erfc(t) dt = exp(-a^2) / sqrt(pi) - a erfc(a) is the Beckmann |cos| Lambda
    over alpha s / 2 (Walter et al. 2007 eq. 27 times |cos|). Piecewise polynomials (the table
    above), within 2 ulp of h in float64 over [0, inf) (tested against mpmath): no erfc call,
    whose two exponentials were most of a Beckmann integrand's time (issue 14), and no
    cancellation between the two terms at large a (h ~ 1 / (2 sqrt(pi) a^2)).
    """
    if a < type(a)(3.0):
        k = int(a * type(a)(4.0))
        # 8 a and its difference to an odd integer below 24 are exact
        return _ierfc_poly(type(a)(8.0) * a - type(a)(2 * k + 1), _ierfc_row(wp.int32(k)))
    u = type(a)(1.0) / (a * a)
    j = 3
    if u > type(a)(0.0625):
        j = 0
    elif u > type(a)(0.027777777777777776):
        j = 1
    elif u > type(a)(0.015625):
        j = 2
    x = u * type(a)(IERFC_UMAP[2 * j]) - type(a)(IERFC_UMAP[2 * j + 1])
    return u * _ierfc_poly(x, _ierfc_row(wp.int32(12 + j)))


def _c_double(v: float) -> str:
    # a C double literal that reads back as v exactly (repr is the shortest round-trip form)
    return repr(float(v))


def _poly_c(n: int, x: str, c: str) -> str:
    # sum_j c[j] x^j, j < n (n = 8, 10, 12 or 16), by Estrin's scheme, as one C expression (x2 and x4
    # are the snippet's)
    quad = [f"(({c}[{j}] + {c}[{j + 1}] * {x}) + ({c}[{j + 2}] + {c}[{j + 3}] * {x}) * x2)" for j in range(0, n - 3, 4)]
    if n == 8:
        return f"({quad[0]} + {quad[1]} * x4)"
    if n == 10:
        return f"(({quad[0]} + {quad[1]} * x4) + ({c}[8] + {c}[9] * {x}) * (x4 * x4))"
    if n == 12:
        return f"({quad[0]} + ({quad[1]} + {quad[2]} * x4) * x4)"
    return f"(({quad[0]} + {quad[1]} * x4) + ({quad[2]} + {quad[3]} * x4) * (x4 * x4))"


def _pieces_c(n: int) -> str:
    # the body of "a in [0, IERFC_A_MAX)": row k = floor(32 a) of the pieces, its first n
    # coefficients (a polynomial of degree n - 1 in x on [-1, 1])
    rows = ",".join("{" + ",".join(_c_double(v) for v in row[:n]) + "}" for row in IERFC_PIECES)
    return f"""
    static const double P[{len(IERFC_PIECES)}][{n}] = {{
{rows}
    }};
    int k = (int)(a * {_c_double(IERFC_PER_UNIT)});
    const double* c = P[k];
    // {2 * IERFC_PER_UNIT} a and its difference to an odd integer are exact
    double x = {_c_double(2 * IERFC_PER_UNIT)} * a - (double)(2 * k + 1);
    double x2 = x * x;
    double x4 = x2 * x2;
    return {_poly_c(n, "x", "c")};"""


# ierfc(a) for float64 a >= 0 as native code: one table look-up instead of a tree of branches
# (the pieces' branches mispredicted at the inner rule's nodes, whose a jumps about: ~15 ns of
# a Beckmann Lambda's ~30 ns, issue 14), and no exp below a = 6 (the pieces are of ierfc itself)
_IERFC_SNIPPET = f"""
if (a >= 0.0 && a < {_c_double(IERFC_A_MAX)}) {{{_pieces_c(len(IERFC_PIECES[0]))}
}}
double a2 = a * a;
if (a2 > 708.0) {{
    // exp(-a^2) < 2^-1021 and ierfc < 1e-3 of it: 0 (exp's subnormal results are slow)
    return 0.0;
}}
static const double T[12] = {{{",".join(_c_double(v) for v in IERFC_TAIL)}}};
double u = 1.0 / a2;
double x = 72.0 * u - 1.0;
double x2 = x * x;
double x4 = x2 * x2;
// exp(-a^2) with the rounding of a^2 put back (a2 + lo = a^2 exactly): without it exp would
// carry a^2's rounding, up to ~700 ulp here
double lo = fma(a, a, -a2);
return (wp::exp(-a2) * (1.0 - lo)) * (u * {_poly_c(12, "x", "T")});
"""

# ierfc(a) to 1.2e-16 absolute (not relative: ierfc(6) = 1.8e-18) for a Smith G: the first 8
# coefficients of the same pieces (the last two are below 1.2e-17 and 7e-20 on every piece; the
# tested error is the full table's), and 0 from a = 6 on. Lambda = ierfc(a) / (2 a) then has an
# error below 2e-16 (1 + Lambda), as with all ten: a shorter chain for the integrand's G
_IERFC_ABS_SNIPPET = f"""
if (a >= 0.0 && a < {_c_double(IERFC_A_MAX)}) {{{_pieces_c(8)}
}}
return 0.0;
"""


# d ierfc / da = -erfc(a): the adjoint, for users' differentiable kernels
@wp.func_native(_IERFC_SNIPPET, adj_snippet="adj_a += -wp::erfc(a) * adj_ret;")
def _ierfc_native(a: wp.float64) -> wp.float64:
    ...


@wp.func_native(_IERFC_ABS_SNIPPET, adj_snippet="adj_a += -wp::erfc(a) * adj_ret;")
def beckmann_ierfc_abs(a: wp.float64) -> wp.float64:
    """ierfc(a) to 1.2e-16 absolute for float64 a >= 0 (0 from a = 6 on, and for nan): what a
    Smith G needs of it (:func:`beckmann_lambda_cos_abs`), by a shorter polynomial of the same
    pieces as :func:`beckmann_ierfc`, whose error is relative."""
    ...


@wp.func
def beckmann_lambda_cos_abs(cos_theta_v: wp.float64, alpha: wp.float64):
    """|cos| Lambda(v) as :func:`beckmann_lambda_cos`, with an error below 6e-17 alpha sin(theta_v)
    (:func:`beckmann_ierfc_abs`) plus a few ulp of |cos| + |cos| Lambda: for a Smith G, where it
    is added to |cos| (1 + Lambda_i) and relative accuracy of a tiny Lambda buys nothing (the
    adaptive integrand's form, issue 14)."""
    zero = wp.float64(0.0)
    z = wp.abs(cos_theta_v)
    s = wp.sqrt(wp.max(zero, wp.float64(1.0) - z * z))
    if s * alpha <= zero:
        # normal incidence or mirror: no shadowing
        return zero
    return alpha * s * wp.float64(0.5) * beckmann_ierfc_abs(z / (alpha * s))


# Lambda(b), b = a^2, as native code (issue 14, thirteenth round): the piece from b's exponent and
# first mantissa bits (no conversion of b to an integer), its local variable by an exact scaling;
# 0 from b = 36 on, below 2^LAMBDA_B_E_MIN (the callers' root form) and for nan
_LAMBDA_B_BITS = LAMBDA_B_PER_OCTAVE.bit_length() - 1  # pieces per octave: 2^_LAMBDA_B_BITS
assert LAMBDA_B_PER_OCTAVE == 1 << _LAMBDA_B_BITS and len(set(map(len, LAMBDA_B_PIECES))) == 1
LAMBDA_B_MIN = wp.constant(wp.float64(2.0**LAMBDA_B_E_MIN))  # a = 1/16: below, the root and ierfc
_LAMBDA_B_SNIPPET = f"""
if (!(b >= {_c_double(2.0 ** LAMBDA_B_E_MIN)} && b < {_c_double(LAMBDA_B_MAX)})) {{
    return 0.0;
}}
static const double P[{len(LAMBDA_B_PIECES)}][{len(LAMBDA_B_PIECES[0])}] = {{
{",".join("{" + ",".join(_c_double(v) for v in row) + "}" for row in LAMBDA_B_PIECES)}
}};
union {{ double d; long long i; }} u, s;
u.d = b;
// b > 0: bits 52.. the biased exponent E, the next {_LAMBDA_B_BITS} down the piece j within the octave
int k = (int)(u.i >> {52 - _LAMBDA_B_BITS}) - {(1023 + LAMBDA_B_E_MIN) * LAMBDA_B_PER_OCTAVE};
int j = k & {LAMBDA_B_PER_OCTAVE - 1};
// 2^(m - e), m = {_LAMBDA_B_BITS + 1}, e = E - 1023: x = 2^(m - e) b - (2^m + 1 + 2 j) in [-1, 1), exact (Sterbenz)
s.i = (long long)({2047 + _LAMBDA_B_BITS} - (int)(u.i >> 52)) << 52;
double x = b * s.d - (double)({2 ** (_LAMBDA_B_BITS + 1) + 1} + 2 * j);
const double* c = P[k];
double x2 = x * x;
double x4 = x2 * x2;
return {_poly_c(len(LAMBDA_B_PIECES[0]), "x", "c")};
"""


@wp.func_native(_LAMBDA_B_SNIPPET)
def _lambda_b_native(b: wp.float64) -> wp.float64:
    ...


@wp.func
def beckmann_lambda_b_table(b: wp.float64):
    """Lambda(b) from the table alone, for b >= ``LAMBDA_B_MIN`` (0 below, from b = 36 on and for nan):
    the integrand's G takes b below LAMBDA_B_MIN to the root form itself (its accuracy at any zo)."""
    return _lambda_b_native(b)


@wp.func
def beckmann_lambda_a2(b: wp.float64):
    """Smith Lambda of a direction with a^2 = b = cot^2(theta) / alpha^2 (float64): ierfc(a) / (2 a)
    within ~6e-17 (1 + Lambda) plus a few ulp, 0 from b = 36 on (Lambda < 1.5e-19 there), infinite at
    b = 0 (the horizon), nan for b < 0 or nan.

    From b, not a: a Smith G from cos(theta) needs no root then (b = z^2 / (alpha^2 (1 - z^2))), the
    root and one division of :func:`beckmann_lambda_cos_abs` less per evaluation (issue 14,
    thirteenth round). Pieces per octave of b (:mod:`bsdf_tab.model.lambda_b_table`) from b = 2^-8;
    below (a < 1/16, within a few degrees of the horizon) ierfc(a) / (2 a) by
    :func:`beckmann_ierfc_abs` (1.2e-16 absolute: 2.1e-16 of Lambda ~ 1 / (2 sqrt(pi) a) there)."""
    zero = wp.float64(0.0)
    if b >= LAMBDA_B_MIN:
        return _lambda_b_native(b)
    if b > zero:
        a = wp.sqrt(b)
        return beckmann_ierfc_abs(a) / (wp.float64(2.0) * a)
    if b == zero:
        # the horizon: Lambda is infinite
        return wp.float64(wp.inf)
    return wp.float64(wp.nan)


@wp.func
def beckmann_ierfc(a: Any):
    """ierfc(a) = int_a^inf erfc(t) dt = exp(-a^2) / sqrt(pi) - a erfc(a), a >= 0 (nan stays nan).

    Generic: exp(-a^2) h(a) with :func:`beckmann_ierfc_scaled`, 0 where a^2 > 708 (the value
    is then below 2^-1021). float64 (the overload below) is native code from
    :mod:`bsdf_tab.model.ierfc_table`.
    """
    a2 = a * a
    if a2 > type(a)(708.0):
        # exp(-a^2) < 2^-1021 and h < 1e-3: subnormal or 0, and exp's subnormal results are slow
        return type(a)(0.0)
    return wp.exp(-a2) * beckmann_ierfc_scaled(a)


@wp.func
def beckmann_ierfc(a: wp.float64):
    """float64: ierfc from 192 polynomials of degree 9 in a on [k / 32, (k + 1) / 32] below a = 6
    (one table row, no branch tree, no exp) and exp(-a^2) u Q(u), u = 1 / a^2, beyond; within a
    few ulp of ierfc (tests/model/test_model_ierfc_table.py). Short pieces, short polynomials:
    degree 9 at 1/32 measured 12% less Beckmann table time than degree 15 at 1/8."""
    return _ierfc_native(a)


@wp.func
def beckmann_lambda_cos(cos_theta_v: Any, alpha: Any):
    """|cos| * Lambda(v) with a = 1 / (alpha tan): alpha s (exp(-a^2) / (2 sqrt(pi)) - a erfc(a) / 2) = alpha s ierfc(a) / 2.

    Exact Smith Lambda (erf(a) - 1) / 2 + exp(-a^2) / (2 a sqrt(pi)), multiplied by cos so that it
    stays finite at grazing (value alpha / (2 sqrt(pi))).
    """
    zero = type(alpha)(0.0)
    z = wp.abs(cos_theta_v)
    s = wp.sqrt(wp.max(zero, type(alpha)(1.0) - z * z))
    if s * alpha <= zero:
        # normal incidence or mirror: no shadowing
        return zero
    # ierfc without erfc and without cancellation (beckmann_ierfc): 0 where a^2 > 708 (below
    # 2^-1022 alpha; most nodes of a small-alpha texel)
    return alpha * s * type(alpha)(0.5) * beckmann_ierfc(z / (alpha * s))


@wp.func
def beckmann_lambda(cos_theta_v: Any, alpha: Any):
    """Smith Lambda(v) for Beckmann (exact, infinite at grazing)."""
    z = wp.abs(cos_theta_v)
    if z <= type(alpha)(0.0):
        # grazing: fully shadowed unless alpha = 0
        if alpha <= type(alpha)(0.0):
            return type(alpha)(0.0)
        return type(alpha)(wp.inf)
    return beckmann_lambda_cos(cos_theta_v, alpha) / z


@wp.func
def _beckmann_slope_cdf(x: Any, cot: Any, norm: Any):
    # unnormalized CDF of the visible slope marginal (cot - x) exp(-x^2) / sqrt(pi), x <= cot
    half = type(x)(0.5)
    return (cot * half * wp.erfc(-x) + half * type(x)(_INV_SQRT_PI) * wp.exp(-x * x)) / norm


@wp.func
def beckmann_sample_vndf(wi: Any, alpha: Any, u1: Any, u2: Any):
    """Sample a visible micro-normal for ``wi`` (wi.z > 0), density G1 max(0, wi.m) D / wi.z."""
    zero = type(alpha)(0.0)
    one = type(alpha)(1.0)
    if alpha <= zero:
        # mirror: the only micro-normal is the macro normal
        return type(wi)(zero, zero, one)
    # stretch to the alpha = 1 configuration
    ws = wp.normalize(type(wi)(alpha * wi[0], alpha * wi[1], wi[2]))
    sin_s = wp.sqrt(ws[0] * ws[0] + ws[1] * ws[1])
    cos_phi = one
    sin_phi = zero
    if sin_s > zero:
        cos_phi = ws[0] / sin_s
        sin_phi = ws[1] / sin_s
    # keep erfinv away from +-1
    eps = type(alpha)(1.0e-7)
    v2 = wp.clamp(type(alpha)(2.0) * u2 - one, -one + eps, one - eps)
    y = wp.erfinv(v2)
    x = zero
    if sin_s < type(alpha)(1.0e-7):
        # normal incidence: slopes are the plain Gaussian exp(-x^2) / sqrt(pi)
        x = wp.erfinv(wp.clamp(type(alpha)(2.0) * u1 - one, -one + eps, one - eps))
    else:
        cot = ws[2] / sin_s
        norm = cot * type(alpha)(0.5) * wp.erfc(-cot) + type(alpha)(_HALF_INV_SQRT_PI) * wp.exp(-cot * cot)
        lo = type(alpha)(-9.0)
        hi = wp.min(cot, type(alpha)(9.0))
        x = wp.clamp(zero, lo, hi)
        for _it in range(100):
            f = _beckmann_slope_cdf(x, cot, norm) - u1
            if f > zero:
                hi = x
            else:
                lo = x
            df = (cot - x) * type(alpha)(_INV_SQRT_PI) * wp.exp(-x * x) / norm
            xn = x - f / wp.max(df, type(alpha)(1.0e-30))
            if xn <= lo or xn >= hi:
                # Newton left the bracket: bisect instead
                xn = type(alpha)(0.5) * (lo + hi)
            if wp.abs(xn - x) <= type(alpha)(1.0e-12) * (one + wp.abs(x)):
                x = xn
                break
            x = xn
    # rotate back to the azimuth of wi, unstretch, and convert slopes to a normal
    sx = alpha * (cos_phi * x - sin_phi * y)
    sy = alpha * (sin_phi * x + cos_phi * y)
    return wp.normalize(type(wi)(-sx, -sy, one))


@wp.func
def beckmann_dcos_sample_tan(u: Any, alpha: Any):
    """tan(theta_m) where the D cos CDF u = 1 - exp(-tan^2 / alpha^2) takes the value ``u`` in [0, 1).

    Inverse-CDF sampling of D(m) cos(theta_m) (Walter et al. 2007 eq. 28): tan = alpha sqrt(-ln(1 - u)).
    """
    return alpha * wp.sqrt(wp.max(type(u)(0.0), -wp.log(type(u)(1.0) - u)))


@wp.func
def beckmann_dcos_tan_of_v(v: Any, alpha: Any):
    """tan(theta_m) at v in [0, 1), where u = 1 - (1 - v)^2 is the D cos CDF.

    tan^2 = -alpha^2 ln((1 - v)^2), with log1p for small v.
    """
    return alpha * wp.sqrt(wp.max(type(v)(0.0), type(v)(-2.0) * log1p_(-v)))


@wp.func
def beckmann_dcos_v_of_theta(theta: Any, alpha: Any):
    """Inverse of :func:`beckmann_dcos_tan_of_v` for theta_m in [0, pi/2]: v = 1 - exp(-tan^2 / (2 alpha^2))."""
    one = type(theta)(1.0)
    if theta >= type(theta)(_HALF_PI) or alpha <= type(alpha)(0.0):
        # the horizon, or a mirror (all of D at theta_m = 0): the whole CDF
        return one
    c = wp.cos(theta)
    s = wp.sin(theta)
    t = s / c
    return -expm1_(-t * t / (type(theta)(2.0) * alpha * alpha))


@wp.func
def beckmann_dlnD_dcos(c: Any, alpha: Any):
    """Bound on |d ln D / d cos theta_m|: 4 / c + 2 / (c^3 alpha^2).

    The amplification of a relative error in cos theta_m into D (the bsdf table's rounding
    estimate); ``c`` is clamped to 1e-300 so that c = 0 gives a huge bound (or +inf), never nan.
    """
    c = wp.max(c, type(c)(1.0e-300))
    return type(c)(4.0) / c + type(c)(2.0) / (c * c * c * alpha * alpha)

"""References: long renders kept outside git (.cache/references/ by default), each with a manifest
(scene, fingerprint, resolution, kind, spp, seconds, version, command) beside it. A reference is rendered
again only when its scene's content (fingerprint), its resolution or its kind changed.

Kinds: unguided of N spp, unguided of S seconds, or guided of S seconds (the default render with an
atlas of its own seeds, not the benchmark's). References take independent samples (sampler=independent)
and write variance layers: only then are those layers unbiased estimates of the reference's own noise,
which the reports take out of every relMSE ('ref. noise removed').
"""
import os

from . import measure, tools

UNGUIDED = ["mode=nee+bsdf", "sampler=independent"]


def unguided_spp(spp):
    return dict(kind="unguided %d spp" % spp, spp=spp, seed=1000003, settings=UNGUIDED)


def unguided_seconds(seconds):
    return dict(kind="unguided %gs" % seconds, seconds=seconds, seed=1000003, settings=UNGUIDED)


def guided_seconds(seconds, connect="off", prep=(), render=(), label=None, caches_at_size=False):
    """A guided reference. Without caustic connections unless CONNECT says otherwise, so that it does not
    rest on the newest estimator it may be judging; where the paths they join are most of the image (a room
    lit through glass) a reference without them stays too noisy, and connect=auto lets its pilot weigh
    them. PREP: preprocessing settings of its own atlas; RENDER: settings instead of the default's;
    CACHES_AT_SIZE: camera caches placed for the reference's size (else for the film's own)."""
    kind = label or ("guided %gs" % seconds + (", connections " + connect if connect != "off" else ""))
    return dict(kind=kind, seconds=seconds, seed=1000005, prep=list(prep), caches_at_size=caches_at_size,
                settings=(list(render) or ["connect=" + connect]) + ["sampler=independent"])


def up_to_date(path, scene, resolution, kind):
    m = measure.read_manifest(path + ".manifest")
    return (os.path.exists(path) and m.get("resolution") == resolution and m.get("kind") == kind
            and m.get("scene_fingerprint") == tools.scene_fingerprint(scene))


def ensure(scene, path, resolution, spec):
    """Renders the reference SPEC of SCENE at RESOLUTION into PATH unless an up-to-date one is there."""
    if up_to_date(path, scene, resolution, spec["kind"]):
        print("reference %s: up to date (%s)" % (path, spec["kind"]))
        return path
    os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
    atlas = None
    if "prep" in spec:
        prep_dir = os.path.splitext(path)[0] + ".prep"
        tools.preprocess(scene, prep_dir, spec["prep"], resolution if spec.get("caches_at_size") else None,
                         seed=1000004)
        atlas = os.path.join(prep_dir, "atlas.h5")
    print("reference %s: rendering (%s)" % (path, spec["kind"]), flush=True)
    cmd = tools.render_cmd(scene, path, atlas=atlas, spp=spec.get("spp"), seconds=spec.get("seconds"),
                           resolution=resolution, seed=spec["seed"], variance=True, settings=spec["settings"])
    seconds, _, _ = tools.run(cmd)
    meta = tools.metadata(path)
    measure.write_text(path + ".manifest", measure.format_manifest(dict(
        scene=scene, scene_fingerprint=meta.get("iris:scene_fingerprint", "?"), resolution=resolution,
        kind=spec["kind"], spp=meta.get("iris:spp", "?"), seconds="%.1f" % seconds,
        version=meta.get("iris:version", "?"), command=" ".join(cmd))))
    print("reference %s: %s spp, %.0f s" % (path, meta.get("iris:spp"), seconds))
    return path


def check(ref, other):
    """Two independent unbiased references differ by their noise alone: the relMSE between them against
    the sum of their own shares (each from its variance layers). A dict for the report."""
    ab, ba = tools.compare(ref, other), tools.compare(other, ref)
    return dict(path=other, spp=tools.metadata(other).get("iris:spp"), relmse=ab["relmse"],
                share_ref=ba.get("relmse_reference_noise") or 0.0, share_other=ab.get("relmse_reference_noise") or 0.0,
                expected=(ab.get("relmse_reference_noise") or 0) + (ba.get("relmse_reference_noise") or 0))


def check_paragraph(c, ref_how, other_how, which):
    """The 'References.' paragraph of a report measured against one reference checked against another."""
    ratio = c["relmse"] / c["expected"] if c["expected"] > 0 else float("nan")
    return ("**References.** %s (its own share of a relMSE %.4g) against %s (`%s`, %s spp, share %.4g): relMSE "
            "between them %.4g, expected from their noise alone %.4g (ratio %.2f; 1 = they differ by noise only). %s"
            % (ref_how, c["share_ref"], other_how, c["path"], c["spp"], c["share_other"], c["relmse"], c["expected"],
               ratio, which))

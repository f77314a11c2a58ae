"""A Mitsuba variant of a published scene file for the published-scene check: the SAME text, with only
  - the integrator: Mitsuba's stock `path`, the scene's own maxDepth and rrDepth kept (a scene without an
    integrator gets `path` with Mitsuba's defaults, maxDepth -1 = unbounded, rrDepth 5: Mitsuba 0.5 itself
    would fall back to `direct`, which renders direct light only and which nobody publishing a scene means);
  - the sampler's sampleCount and seed (`seed` is read by the independent sampler of the build of
    scripts/peers/build-mitsuba.sh; stock Mitsuba 0.5 ignores it and repeats one fixed seed);
  - the film's width and height, and its componentFormat set to float32 (storage only: a half float
    overflows at 65504, which a sun disk exceeds);
  - a scene version 0.6.x written as 0.5.0: Mitsuba 0.5.0 refuses a file of another minor version as "from
    an incompatible future version", and the 0.6 cores (MARS, the improved-path-guiding fork) read the same
    format as 0.5.
Edits are made on the text (comments, order and layout stay as published) and checked by parsing the
result. No tool is run here, so that selftest can check it.
"""
import re
import xml.etree.ElementTree as ET

_COMMENT = re.compile(r"<!--.*?-->", re.S)


class SceneError(Exception):
    pass


def _masked(text):
    """The text with every comment blanked (same length), so that searches skip commented-out XML."""
    return _COMMENT.sub(lambda m: " " * len(m.group(0)), text)


def _element_span(masked, tag, start=0, end=None):
    """(begin, end of start tag, end) of the first <tag ...> element at or after START (before END),
    nesting of the same tag counted; None if there is none."""
    end = len(masked) if end is None else end
    m = re.compile(r"<%s\b" % tag).search(masked, start, end)
    if not m:
        return None
    open_end = masked.index(">", m.end())
    if masked[open_end - 1] == "/":
        return m.start(), open_end + 1, open_end + 1
    depth, pos = 1, open_end + 1
    tok = re.compile(r"<(/?)%s\b[^>]*?(/?)>" % tag)
    while depth:
        t = tok.search(masked, pos, end)
        if not t:
            raise SceneError("<%s> at offset %d is not closed" % (tag, m.start()))
        if t.group(1):
            depth -= 1
        elif not t.group(2):
            depth += 1
        pos = t.end()
    return m.start(), open_end + 1, pos


def _defaults(root):
    return {d.get("name"): d.get("value") for d in root if d.tag == "default"}


def _resolve(value, defaults):
    """A parameter value with $name substituted from the scene's <default> elements."""
    return re.sub(r"\$(\w+)", lambda m: defaults.get(m.group(1), m.group(0)), value or "")


def _child_value(elem, tag, name):
    for c in elem:
        if c.tag == tag and c.get("name") == name:
            return c.get("value")
    return None


def inspect(text):
    """What the check needs from a scene file: film size (Mitsuba's defaults 768 x 576), the integrator's
    type, maxDepth and rrDepth (as written, $names resolved), the sampler's type."""
    try:
        root = ET.fromstring(text)
    except ET.ParseError as e:
        raise SceneError("not XML: %s" % e)
    if root.tag != "scene":
        raise SceneError("the root element is <%s>, not <scene>" % root.tag)
    d = _defaults(root)
    info = dict(width=768, height=576, integrator=None, maxDepth="-1", rrDepth="5", sampler=None)
    integ = root.find("integrator")
    if integ is not None:
        info["integrator"] = integ.get("type")
        inner = integ
        while _child_value(inner, "integer", "maxDepth") is None and inner.find("integrator") is not None:
            inner = inner.find("integrator")  # adaptive/irrcache wrap the integrator that holds the depths
        for k in ("maxDepth", "rrDepth"):
            v = _child_value(inner, "integer", k)
            if v is not None:
                info[k] = _resolve(v, d)
    sensor = root.find("sensor")
    if sensor is not None:
        film = sensor.find("film")
        if film is not None:
            for k in ("width", "height"):
                v = _child_value(film, "integer", k)
                if v is not None:
                    info[k] = int(_resolve(v, d))
        sampler = sensor.find("sampler")
        if sampler is not None:
            info["sampler"] = sampler.get("type")
    return info


def _indent_of(text, pos):
    line_start = text.rfind("\n", 0, pos) + 1
    return re.match(r"[ \t]*", text[line_start:pos]).group(0)


def _set_integer(text, begin, end, name, value, inner_indent):
    """Set <integer name=NAME value=.../> directly inside the element text[begin:end] (its start tag ends
    before the first child); inserted after the start tag when absent. Returns the new text."""
    masked = _masked(text)
    pat = re.compile(r"<integer\s+name\s*=\s*\"%s\"\s+value\s*=\s*\"[^\"]*\"\s*/>" % name)
    m = pat.search(masked, begin, end)
    if m:
        new = '<integer name="%s" value="%s"/>' % (name, value)
        return text[:m.start()] + new + text[m.end():]
    tag_end = masked.index(">", begin) + 1
    return text[:tag_end] + "\n%s<integer name=\"%s\" value=\"%s\"/>" % (inner_indent, name, value) + text[tag_end:]


def _set_string(text, begin, end, name, value, inner_indent):
    masked = _masked(text)
    pat = re.compile(r"<string\s+name\s*=\s*\"%s\"\s+value\s*=\s*\"[^\"]*\"\s*/>" % name)
    m = pat.search(masked, begin, end)
    if m:
        return text[:m.start()] + '<string name="%s" value="%s"/>' % (name, value) + text[m.end():]
    tag_end = masked.index(">", begin) + 1
    return text[:tag_end] + "\n%s<string name=\"%s\" value=\"%s\"/>" % (inner_indent, name, value) + text[tag_end:]


def _open_element(text, span, tag, indent):
    """An element written as <tag .../> is reopened as <tag ...></tag> so that children can go in."""
    b, tag_end, e = span
    if tag_end != e:
        return text, span
    head = text[b:tag_end - 2].rstrip()
    new = head + ">\n" + indent + "</%s>" % tag
    text = text[:b] + new + text[e:]
    return text, (b, b + len(head) + 1, b + len(new))


def variant(text, spp, seed, width, height):
    """The Mitsuba variant of scene TEXT (see the module's doc). Raises SceneError when the file has no
    sensor, film or sampler to edit."""
    info = inspect(text)
    masked = _masked(text)
    scene = _element_span(masked, "scene")
    v = re.compile(r"(\bversion\s*=\s*\")0\.6\.\d+(\")").search(masked, scene[0], scene[1])
    if v:
        text = text[:v.start()] + v.group(1) + "0.5.0" + v.group(2) + text[v.end():]
        masked = _masked(text)
        scene = _element_span(masked, "scene")
    integ = _element_span(masked, "integrator", scene[1], scene[2] - len("</scene>"))
    body = '<integrator type="path">\n%s\t<integer name="maxDepth" value="%s"/>\n%s\t<integer name="rrDepth" ' \
           'value="%s"/>\n%s</integrator>'
    if integ:
        ind = _indent_of(text, integ[0])
        text = text[:integ[0]] + body % (ind, info["maxDepth"], ind, info["rrDepth"], ind) + text[integ[2]:]
    else:
        # after the last top-level <default>, else right after <scene ...>: $names stay resolvable
        pos = top = scene[1]
        lead = re.compile(r"\s*<default\b[^>]*/>")
        while lead.match(masked, pos):  # the <default>s that open the scene (others sit inside shapes)
            pos = lead.match(masked, pos).end()
        ind = "\t"
        nxt = re.search(r"\n([ \t]*)<", text[top:])
        if nxt:
            ind = nxt.group(1)
        text = text[:pos] + "\n" + ind + body % (ind, info["maxDepth"], ind, info["rrDepth"], ind) + text[pos:]
    for tag, edits in (("sampler", (("integer", "sampleCount", spp), ("integer", "seed", seed))),
                       ("film", (("integer", "width", width), ("integer", "height", height),
                                 ("string", "componentFormat", "float32")))):
        masked = _masked(text)
        sensor = _element_span(masked, "sensor")
        if not sensor:
            raise SceneError("no <sensor>")
        span = _element_span(masked, tag, sensor[1], sensor[2])
        if not span:
            raise SceneError("the sensor has no <%s>" % tag)
        ind = _indent_of(text, span[0])
        text, span = _open_element(text, span, tag, ind)
        for kind, name, value in edits:
            masked = _masked(text)
            span = _element_span(masked, tag, _element_span(masked, "sensor")[1])
            setter = _set_integer if kind == "integer" else _set_string
            text = setter(text, span[0], span[2], name, value, ind + "\t")
    check(text, spp, seed, width, height)
    return text


def check(text, spp, seed, width, height):
    """The variant parses and says what it should."""
    root = ET.fromstring(text)
    integ = root.findall("integrator")
    if len(integ) != 1 or integ[0].get("type") != "path":
        raise SceneError("variant: the integrator is not one stock path")
    sensor = root.find("sensor")
    sampler, film = sensor.find("sampler"), sensor.find("film")
    got = (_child_value(sampler, "integer", "sampleCount"), _child_value(sampler, "integer", "seed"),
           _child_value(film, "integer", "width"), _child_value(film, "integer", "height"))
    if got != (str(spp), str(seed), str(width), str(height)):
        raise SceneError("variant: sampler/film not as asked: %r" % (got,))

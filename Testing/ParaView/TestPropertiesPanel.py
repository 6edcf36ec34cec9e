"""The Properties panel of the plugin's proxies, from their server-manager XML: readable labels that keep the Python
names, groups (Data, Size, Training, Advanced; the Neural Volume render settings), documentation for every proxy and
property, ranges that match what the C++ accepts (the domain's limits work, one step beyond them is refused or
clamped), the GPU-only settings hidden where no GPU is usable, the icons, and the training log opening once in a
line chart of PSNR and loss over the steps (the metrics table in no view)."""
import math
import os
import re
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

import numpy as np  # noqa: E402
import paraview  # noqa: E402
from paraview.simple import *  # noqa: E402,F401,F403
from paraview import servermanager  # noqa: E402
from vtkmodules.vtkCommonDataModel import vtkImageData  # noqa: E402
from vtkmodules.util.numpy_support import numpy_to_vtk  # noqa: E402

nvtest.load_plugin(globals(), scripted=False)
check, log = nvtest.check, nvtest.log
pxm = servermanager.ProxyManager().SMProxyManager

PROXIES = [("filters", "NeuralCompress"), ("sources", "NeuralVolumeReader"), ("writers", "NeuralVolumeWriter"),
           ("representations", "NeuralVolumeRepresentation"), ("filters", "NeuralParticleField")]
if pxm.GetPrototypeProxy("sources", "NeuralVDBReader") is not None:  # built with OpenVDB
    PROXIES += [("sources", "NeuralVDBReader"), ("writers", "NeuralVDBWriter")]
PROPERTY_TAGS = ("IntVectorProperty", "DoubleVectorProperty", "IdTypeVectorProperty", "StringVectorProperty",
                 "InputProperty", "ProxyProperty", "Property")


def children(element, name=None):
    for i in range(element.GetNumberOfNestedElements()):
        child = element.GetNestedElement(i)
        if name is None or child.GetName() == name:
            yield child


def decorators(element):
    """Every PropertyWidgetDecorator under element (composite decorators included)."""
    if element is None:
        return []
    found = [element] if element.GetName() == "PropertyWidgetDecorator" else []
    for child in children(element):
        found += decorators(child)
    return found


def own_definition(group, name):
    """The proxy's own XML (not merged with a base proxy)."""
    definition = pxm.GetProxyDefinitionManager().GetProxyDefinition(group, name, False)
    check(definition is not None, "%s.%s: has an XML definition" % (group, name))
    return definition


def text_of(element):
    """Documentation text of a property or proxy element (character data and short/long help)."""
    doc = element.FindNestedElementByName("Documentation")
    return doc, (doc.GetCharacterData() or "").strip() if doc is not None else ""


# --- Labels and documentation of every proxy and property ---------------------------------------------------
for group, name in PROXIES + [("representations", "NeuralTrainingLogChartRepresentation")]:
    definition = own_definition(group, name)
    doc, text = text_of(definition)
    check(doc is not None and len(text) > 40, "%s: proxy documentation present" % name)
    if doc is not None:
        check(len(doc.GetAttribute("short_help") or "") > 10 and len(doc.GetAttribute("long_help") or "") > 30,
              "%s: short_help and long_help present" % name)
    for element in children(definition):
        if element.GetName() not in PROPERTY_TAGS:
            continue
        pname = element.GetAttribute("name")
        _, ptext = text_of(element)
        check(len(ptext) > 10, "%s.%s: documented" % (name, pname))
        if element.GetAttribute("override"):
            continue  # the chart's overridden properties keep ParaView's labels
        label = element.GetAttribute("label")
        if element.GetName() == "InputProperty":
            continue
        check(label is not None, "%s.%s: has a label" % (name, pname))
        if label is None:
            continue
        # Python names come from labels (a representation's from the names it is exposed under): a label must
        # give back the property's name.
        check(group == "representations" or paraview.make_name_valid(label) == pname,
              "%s.%s: label %r keeps the Python name (%r)" % (name, pname, label, paraview.make_name_valid(label)))
        # No split acronym ("P SNRInterval"): every word is a word.
        check(re.search(r"\b[A-Z] [A-Z]", label) is None and re.search(r"[a-z][A-Z][a-z]", label) is None,
              "%s.%s: readable label %r" % (name, pname, label))

nc_proto = pxm.GetPrototypeProxy("filters", "NeuralCompress")
labels = {p: nc_proto.GetProperty(p).GetXMLLabel() for p in ("PSNRInterval", "TargetPSNR", "NetworkCacheMiB",
                                                              "TrainInBackground", "Log2TableSize")}
check(labels == {"PSNRInterval": "PSNR Interval", "TargetPSNR": "Target PSNR",
                 "NetworkCacheMiB": "Network Cache (MiB)", "TrainInBackground": "Train In Background",
                 "Log2TableSize": "Log2 Table Size"}, "filter labels as written: %r" % labels)

# --- Groups ----------------------------------------------------------------------------------------------------
groups = {}
for i in range(nc_proto.GetNumberOfPropertyGroups()):
    g = nc_proto.GetPropertyGroup(i)
    groups[g.GetXMLLabel()] = ([g.GetPropertyName(k) for k in range(g.GetNumberOfProperties())],
                               g.GetPanelVisibility())
check(list(groups) == ["Data", "Size", "Training", "Advanced"], "filter groups: %r" % list(groups))
EXPECTED_GROUPS = {
    "Data": ["SelectInputScalars", "VectorMode", "VectorComponent", "OutputMode", "OutputResolution", "Sampling",
             "SamplingDimensions", "ProbePoints", "MemoryBudget", "BypassPageCache", "ParticleField", "ParticleKernel",
             "ParticleRadius",
             "ParticleRadiusArray"],
    "Size": ["TargetCompressionRatio", "SizeForPSNR", "Log2TableSize", "StoragePrecision", "MaxError", "Levels",
             "FeaturesPerLevel", "BaseResolution", "FinestResolution", "NetworkWidth", "HiddenLayers"],
    "Advanced": ["BatchSize", "LearningRate", "LearningRateSchedule", "Loss", "Seed", "PSNRInterval",
                 "KeepBestNetwork", "Deterministic", "WarmStart", "NetworkCacheMiB", "Threads", "Device",
                 "TrainingStrategy"]}
for label, members in EXPECTED_GROUPS.items():
    check(groups.get(label, ([], ""))[0] == members, "group %s holds %r (has %r)"
          % (label, members, groups.get(label, ([], ""))[0]))
check(groups.get("Advanced", ([], ""))[1] == "advanced", "the Advanced group is advanced")
# The status line (state, steps, PSNR, time left) heads the Training group and is shown in the panel.
check(groups.get("Training", ([], ""))[0][:1] == ["TrainingStatus"], "Training Status heads the Training group")
check(nc_proto.GetProperty("TrainingStatus").GetPanelVisibility() == "default", "Training Status is shown in the panel")
for p in EXPECTED_GROUPS["Advanced"]:
    check(nc_proto.GetProperty(p).GetPanelVisibility() == "advanced", "%s is an advanced property" % p)
# Every property the panel shows is in a group.
grouped = {p for members, _ in groups.values() for p in members}
iterator = nc_proto.NewPropertyIterator()
iterator.Begin()
while not iterator.IsAtEnd():
    key, prop = iterator.GetKey(), iterator.GetProperty()
    if key != "Input" and prop.GetPanelVisibility() != "never":
        check(key in grouped, "panel property %s is in a group" % key)
    iterator.Next()

# The Neural Volume render settings: three groups of the image representation, each shown for Neural Volume only.
image_repr = pxm.GetPrototypeProxy("representations", "UniformGridRepresentation")
render_groups = {}
for i in range(image_repr.GetNumberOfPropertyGroups()):
    g = image_repr.GetPropertyGroup(i)
    if (g.GetXMLLabel() or "").startswith("Neural Volume"):
        render_groups[g.GetXMLLabel()] = [g.GetPropertyName(k) for k in range(g.GetNumberOfProperties())]
        hints = g.GetHints()
        decorator = hints.FindNestedElementByName("PropertyWidgetDecorator") if hints else None
        check(decorator is not None and decorator.GetAttribute("property") == "Representation"
              and decorator.GetAttribute("value") == "Neural Volume",
              "group %s is shown for the Neural Volume representation only" % g.GetXMLLabel())
check(render_groups.get("Neural Volume") == ["RenderPath", "ShadingMode", "StreamingSamples", "SamplesPerPixel",
                                              "TargetSamples", "Denoise"]
      and render_groups.get("Neural Volume Lighting") == ["FollowViewLight", "LightDirection", "MaxBounces"]
      and render_groups.get("Neural Volume Quality") == ["SampleDistance", "DecodeResolution",
                                                         "EmptySpaceSkipping", "InteractiveImageScale", "AdaptiveInteractiveScale",
                                                         "MaximumInteractiveFrameRate", "CudaGLInterop"],
      "render settings grouped: %r" % render_groups)


# --- Domains against what the C++ accepts ----------------------------------------------------------------------
def range_of(proxy, name):
    prop = proxy.GetProperty(name)
    domain = prop.FindDomain("vtkSMIntRangeDomain") or prop.FindDomain("vtkSMDoubleRangeDomain")
    if domain is None:
        return None
    lo = domain.GetMinimum(0) if domain.GetMinimumExists(0) else None
    hi = domain.GetMaximum(0) if domain.GetMaximumExists(0) else None
    return lo, hi


def enum_values(proxy, name):
    domain = proxy.GetProperty(name).FindDomain("vtkSMEnumerationDomain")
    return sorted(domain.GetEntryValue(i) for i in range(domain.GetNumberOfEntries()))


# (min, max) the C++ accepts: vtkSetClampMacro limits of the filter and the mapper, and the engine's validation
# (Cuda/Core/Config.cpp, RenderSetup.cpp); None = the type's limit.
FILTER_RANGES = {"VectorComponent": (0, 255), "TrainingSteps": (0, None), "TimeBudget": (0, None),
                 "TargetPSNR": (0, 1000), "SizeForPSNR": (0, 1000), "BatchSize": (1, 1 << 24), "LearningRate": (1e-9, None),
                 "Seed": (0, None), "TargetCompressionRatio": (0, None), "Levels": (1, 32),
                 "BaseResolution": (2, 4096), "FinestResolution": (0, 1 << 20), "HiddenLayers": (1, 8),
                 "Threads": (0, 1024), "ProbePoints": (0, 1 << 26), "PSNRInterval": (0, None),
                 "NetworkCacheMiB": (0, 1 << 20), "ContinueSteps": (1, None), "SamplingDimensions": (0, 1024),
                 "OutputResolution": (0, None)}
RENDER_RANGES = {"StreamingSamples": (1, 1024), "SamplesPerPixel": (1, 4096), "TargetSamples": (1, 1 << 20),
                 "MaxBounces": (0, 1024), "DecodeResolution": (0, 8192), "InteractiveImageScale": (0.05, 1.0),
                 "MaximumInteractiveFrameRate": (0, 1000), "SampleDistance": (0, None)}
for name, expected in FILTER_RANGES.items():
    check(range_of(nc_proto, name) == expected, "NeuralCompress.%s range %r == %r"
          % (name, range_of(nc_proto, name), expected))
nv_proto = pxm.GetPrototypeProxy("representations", "NeuralVolumeRepresentation")
for name, expected in RENDER_RANGES.items():
    got = range_of(nv_proto, name)
    check(got is not None and all(a == b or (a is not None and b is not None and abs(a - b) < 1e-12)
                                  for a, b in zip(got, expected)),
          "NeuralVolumeRepresentation.%s range %r == %r" % (name, got, expected))
check(enum_values(nc_proto, "Log2TableSize") == [0] + list(range(10, 27)), "Log2TableSize offers 0 and 10..26 only")
check(enum_values(nc_proto, "FeaturesPerLevel") == [1, 2, 4, 8], "FeaturesPerLevel offers 1, 2, 4, 8")
check(enum_values(nc_proto, "NetworkWidth") == [16, 32, 64, 128], "NetworkWidth offers 16..128")

x, y, z = np.meshgrid(*(np.linspace(0, 1, 8),) * 3, indexing="ij")
values = np.transpose(np.sin(3 * x) * np.cos(2 * y) + z, (2, 1, 0)).astype(np.float32).ravel()
image = vtkImageData()
image.SetDimensions(8, 8, 8)
array = numpy_to_vtk(values, deep=1)
array.SetName("f")
image.GetPointData().SetScalars(array)
producer = TrivialProducer()
producer.GetClientSideObject().SetOutput(image)
TINY = dict(SelectInputScalars=["POINTS", "f"], TrainInBackground=0, TrainingSteps=2, BatchSize=256, Levels=2,
            FeaturesPerLevel=1, NetworkWidth=16, HiddenLayers=1, Threads=1, PSNRInterval=0, Log2TableSize=10)


def compress(**settings):
    """Runs a tiny compression; returns (network present, error text, the filter's PrintSelf)."""
    params = dict(TINY)
    params.update(settings)
    filt = NeuralCompress(Input=producer, **params)
    with nvtest.captured_messages() as messages:
        filt.UpdatePipeline()
        out = servermanager.Fetch(filt)
    printed = str(filt.GetClientSideObject())
    Delete(filt)
    has_network = out.GetFieldData().GetArray("NeuralNetwork") is not None
    return has_network, messages[0], printed, out


def accepted(label, **settings):
    ok, text, _, _ = compress(**settings)
    check(ok and "ERROR" not in text, "%s: accepted (network present; messages %r)" % (label, text[-300:]))


def refused(label, **settings):
    ok, text, _, _ = compress(**settings)
    check(not ok and "ERROR" in text, "%s: refused with an error (network %s; messages %r)" % (label, ok, text[-300:]))


# Validated by the engine: the domain's limits train, one step beyond is an error.
accepted("Levels = min 1", Levels=1)
refused("Levels = 0", Levels=0)
accepted("Levels = max 32", Levels=32)
refused("Levels = 33", Levels=33)
accepted("HiddenLayers = min 1", HiddenLayers=1)
refused("HiddenLayers = 0", HiddenLayers=0)
accepted("HiddenLayers = max 8", HiddenLayers=8)
refused("HiddenLayers = 9", HiddenLayers=9)
accepted("BaseResolution = min 2", BaseResolution=2)
refused("BaseResolution = 1", BaseResolution=1)
accepted("BaseResolution = max 4096", BaseResolution=4096, FinestResolution=4096)
refused("BaseResolution = 4097", BaseResolution=4097, FinestResolution=8192)
accepted("FinestResolution = max 2^20", FinestResolution=1 << 20)
refused("FinestResolution = 2^20 + 1", FinestResolution=(1 << 20) + 1)
accepted("Log2TableSize = min entry 10", Log2TableSize=10)
refused("Log2TableSize = 9", Log2TableSize=9)
accepted("Log2TableSize = max entry 26", Log2TableSize=26)
refused("Log2TableSize = 27", Log2TableSize=27)
accepted("LearningRate = min 1e-9", LearningRate=1e-9)
refused("LearningRate = 0", LearningRate=0.0)
refused("FeaturesPerLevel = 3 (not an entry)", FeaturesPerLevel=3)
refused("NetworkWidth = 48 (not an entry)", NetworkWidth=48)
refused("Threads = 1025", Threads=1025)

# Clamped by the filter's setters: one step beyond the domain reads back as the domain's limit.
ok, text, printed, out = compress(TrainingSteps=-1, ContinueSteps=0, Seed=-1, PSNRInterval=-1, TimeBudget=-1.0,
                                  TargetCompressionRatio=-1.0, TargetPSNR=1001.0, SizeForPSNR=1001.0,
                                  NetworkCacheMiB=(1 << 20) + 1,
                                  VectorComponent=256, BatchSize=0)
fields = dict(re.findall(r"^\s*(\w+): (.*)$", printed, re.M))
for name, expected in (("TrainingSteps", "0"), ("ContinueSteps", "1"), ("Seed", "0"), ("PSNRInterval", "0"),
                       ("TimeBudget", "0"), ("TargetCompressionRatio", "0"), ("TargetPSNR", "1000"),
                       ("SizeForPSNR", "1000"),
                       ("NetworkCacheMiB", str(1 << 20)), ("VectorComponent", "255"), ("BatchSize", "1")):
    check(fields.get(name) == expected, "%s beyond its domain is clamped to %s (reads %r)"
          % (name, expected, fields.get(name)))

# --- GPU-only settings hidden where no GPU is usable ------------------------------------------------------------
for group, name, props in (("filters", "NeuralCompress", ("Device", "TrainingStrategy")),
                           ("sources", "NeuralVolumeReader", ("Device",))):
    proto = pxm.GetPrototypeProxy(group, name)
    check(proto.GetProperty("GPUUsable") is not None and proto.GetProperty("GPUUsable").GetInformationOnly(),
          "%s: information-only GPUUsable" % name)
    for p in props:
        found = [d for d in decorators(proto.GetProperty(p).GetHints())
                 if d.GetAttribute("type") == "GenericDecorator" and d.GetAttribute("mode") == "visibility"
                 and d.GetAttribute("property") == "GPUUsable" and d.GetAttribute("value") == "1"]
        check(len(found) == 1, "%s.%s: hidden unless GPUUsable is 1" % (name, p))
ok, text, printed, out = compress(TrainingSteps=2)
probe = NeuralCompress(Input=producer, **TINY)
probe.UpdatePipelineInformation()
gpu = probe.GetPropertyValue("GPUUsable")
device = nvtest.field_value(out, "NeuralDevice")
log("GPUUsable = %r, Auto trained on %r" % (gpu, device))
check(gpu in (0, 1) and (gpu == 1) == (str(device).upper().startswith("CUDA")),
      "GPUUsable (%r) matches the device Auto picked (%r)" % (gpu, device))
Delete(probe)

# --- Icons ------------------------------------------------------------------------------------------------------
hints = nc_proto.GetHints()
menu = hints.FindNestedElementByName("ShowInMenu")
check(menu is not None and menu.GetAttribute("category") == "Neural"
      and menu.GetAttribute("icon") == ":/NeuralVolume/Icons/NeuralCompress.svg", "filter menu entry has the icon")
icons = [h.GetAttribute("name") for h in children(hints, "PipelineIcon")]
check(icons == [":/NeuralVolume/Icons/NeuralVolume.svg", "SpreadSheetView"],
      "pipeline icons: the Neural Volume for the decoded output, a table for the metrics: %r" % icons)
icon_dir = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "Plugin", "Icons")
with open(os.path.join(icon_dir, "NeuralVolumeIcons.qrc")) as f:
    qrc = f.read()
for icon in ("NeuralCompress.svg", "NeuralVolume.svg"):
    path = os.path.join(icon_dir, icon)
    check(os.path.exists(path) and "<svg" in open(path).read() and icon in qrc,
          "%s exists and is in the plugin's Qt resource" % icon)

# --- The training log opens once in a line chart of PSNR and loss over the steps --------------------------------
controller = servermanager.vtkSMParaViewPipelineControllerWithRendering()
check(controller.GetPreferredViewType(nc_proto, 1) == "XYChartView", "port 1 (Training Log) opens in a line chart")
check(controller.GetPreferredViewType(nc_proto, 2) == "None", "port 2 (Metrics) opens in no view")
filt = NeuralCompress(Input=producer, **dict(TINY, TrainingSteps=30, PSNRInterval=10))
filt.UpdatePipeline()
check(controller.GetPreferredViewType(filt.SMProxy, 0) is None, "port 0 goes to the active render view")
chart = CreateView("XYChartView")
layout = CreateLayout("log")
AssignViewToLayout(chart, layout)
shown = controller.ShowInPreferredView(filt.SMProxy, 1, chart.SMProxy)
check(shown is not None and shown.GetXMLName() == "XYChartView", "the training log is shown in the chart")
views_before = len(GetViews())
for repeat in range(2):  # shown again (a later Apply): the same view, no new one
    controller.ShowInPreferredView(filt.SMProxy, 1, chart.SMProxy)
check(len(GetViews()) == views_before, "showing the log again opens no new view (%d -> %d)"
      % (views_before, len(GetViews())))
rep = servermanager._getPyProxy(chart.SMProxy.FindRepresentation(filt.SMProxy, 1))
check(rep.SMProxy.GetXMLName() == "NeuralTrainingLogChartRepresentation", "the log uses the training-log chart")
visibility = dict(zip(rep.GetPropertyValue("SeriesVisibility")[::2], rep.GetPropertyValue("SeriesVisibility")[1::2]))
corner = dict(zip(rep.GetPropertyValue("SeriesPlotCorner")[::2], rep.GetPropertyValue("SeriesPlotCorner")[1::2]))
check(rep.GetPropertyValue("UseIndexForXAxis") == 0 and rep.GetPropertyValue("XArrayName") == "Step",
      "X axis is the step")
check(visibility == {"PSNR": "1", "Loss": "1", "LearningRate": "0", "ElapsedSeconds": "0", "Step": "0"},
      "PSNR and loss shown: %r" % visibility)
check(corner.get("PSNR") == "0" and corner.get("Loss") == "1", "PSNR on the left axis, loss on the right")
log_table = servermanager.Fetch(filt, idx=1)
columns = [log_table.GetColumnName(c) for c in range(log_table.GetNumberOfColumns())]
check(sorted(columns) == sorted(visibility), "the chart's series are the log's columns %r" % columns)

nvtest.finish()

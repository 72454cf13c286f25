/* FMI 2.0 co-simulation front end of a fullspeed FMU (fs_fmu.h): the
 * standard's functions (fmi2Functions.h, the Modelica Association's header)
 * over fs_fmi_inst. Real, Integer and Boolean variables; one doStep is one
 * control period; a stop of the closed loop returns fmi2Discard with
 * fmi2Terminated true. No FMU state, no derivatives, no model exchange. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../fmi2/fmi2Functions.h"
#include "fs_fmi_inst.h"

typedef struct {
    fmi2CallbackFunctions cb;
} front2;

static void log_fmi2(fs_inst *inst, int status, const char *category, const char *message)
{
    const front2 *f = inst->front;
    if (f->cb.logger && (status >= FS_ST_ERROR || inst->logging))
        f->cb.logger(f->cb.componentEnvironment, inst->name, (fmi2Status)status, category, "%s", message);
}

#define INST ((fs_inst *)c)

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories, const fmi2String categories[])
{
    (void)nCategories, (void)categories;
    INST->logging = loggingOn;
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn)
{
    (void)fmuResourceLocation, (void)visible;
    const char *why = NULL;
    if (fmuType != fmi2CoSimulation)
        why = "model exchange: this FMU is co-simulation only";
    else if (fmuGUID && strcmp(fmuGUID, FS_FMU_TOKEN) != 0)
        why = "the GUID is not this FMU's (its modelDescription.xml belongs to another build)";
    if (why) {
        if (functions && functions->logger)
            functions->logger(functions->componentEnvironment, instanceName, fmi2Error, "logStatusError", "%s", why);
        return NULL;
    }
    front2 *f = calloc(1, sizeof(*f));
    if (!f) return NULL;
    if (functions) f->cb = *functions;
    fs_inst *inst = fs_inst_new(instanceName, log_fmi2, f, loggingOn);
    if (!inst) free(f);
    return inst;
}

void fmi2FreeInstance(fmi2Component c)
{
    if (!c) return;
    free(INST->front);
    fs_inst_free(INST);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance, fmi2Real startTime,
                               fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    (void)toleranceDefined, (void)tolerance, (void)stopTimeDefined, (void)stopTime;
    if (startTime != 0.0) {
        snprintf(INST->msg, sizeof(INST->msg), "start time %.9g s: the drive and the scenario start at t = 0", startTime);
        if (INST->log) INST->log(INST, FS_ST_ERROR, "logStatusError", INST->msg);
        return fmi2Error;
    }
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) { return (fmi2Status)fs_inst_enter_init(INST, 0.0); }
fmi2Status fmi2ExitInitializationMode(fmi2Component c) { return (fmi2Status)fs_inst_exit_init(INST); }
fmi2Status fmi2Terminate(fmi2Component c) { return (fmi2Status)fs_inst_terminate(INST); }
fmi2Status fmi2Reset(fmi2Component c) { return (fmi2Status)fs_inst_reset(INST); }

/* Get and set: each value reference checked, then copied. */
#define GETSET(Name, CType, kind)                                                                              \
    fmi2Status fmi2Get##Name(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, CType value[])        \
    {                                                                                                          \
        for (size_t k = 0; k < nvr; ++k) {                                                                     \
            if (fs_inst_check(INST, vr[k], kind, 0) != FS_ST_OK) return fmi2Error;                             \
            value[k] = (CType)fs_inst_value(INST, vr[k]);                                                      \
        }                                                                                                      \
        return fmi2OK;                                                                                         \
    }                                                                                                          \
    fmi2Status fmi2Set##Name(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const CType value[])  \
    {                                                                                                          \
        for (size_t k = 0; k < nvr; ++k) {                                                                     \
            if (fs_inst_check(INST, vr[k], kind, 1) != FS_ST_OK) return fmi2Error;                             \
            fs_inst_set(INST, vr[k], (double)value[k]);                                                        \
        }                                                                                                      \
        return fmi2OK;                                                                                         \
    }

GETSET(Real, fmi2Real, FS_FMU_REAL)
GETSET(Integer, fmi2Integer, FS_FMU_INT)
GETSET(Boolean, fmi2Boolean, FS_FMU_BOOL)

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[])
{
    (void)vr, (void)nvr, (void)value;
    return (fmi2Status)fs_inst_unsupported(INST, "fmi2GetString (no String variables)");
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[])
{
    (void)vr, (void)nvr, (void)value;
    return (fmi2Status)fs_inst_unsupported(INST, "fmi2SetString (no String variables)");
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    (void)FMUstate;
    return (fmi2Status)fs_inst_unsupported(INST, "fmi2GetFMUstate");
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate)
{
    (void)FMUstate;
    return (fmi2Status)fs_inst_unsupported(INST, "fmi2SetFMUstate");
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    (void)FMUstate;
    return (fmi2Status)fs_inst_unsupported(INST, "fmi2FreeFMUstate");
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size)
{
    (void)FMUstate, (void)size;
    return (fmi2Status)fs_inst_unsupported(INST, "fmi2SerializedFMUstateSize");
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[], size_t size)
{
    (void)FMUstate, (void)serializedState, (void)size;
    return (fmi2Status)fs_inst_unsupported(INST, "fmi2SerializeFMUstate");
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate)
{
    (void)serializedState, (void)size, (void)FMUstate;
    return (fmi2Status)fs_inst_unsupported(INST, "fmi2DeSerializeFMUstate");
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[])
{
    (void)vUnknown_ref, (void)nUnknown, (void)vKnown_ref, (void)nKnown, (void)dvKnown, (void)dvUnknown;
    return (fmi2Status)fs_inst_unsupported(INST, "fmi2GetDirectionalDerivative");
}

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[])
{
    (void)vr, (void)nvr, (void)order, (void)value;
    return (fmi2Status)fs_inst_unsupported(INST, "fmi2SetRealInputDerivatives");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[])
{
    (void)vr, (void)nvr, (void)order, (void)value;
    return (fmi2Status)fs_inst_unsupported(INST, "fmi2GetRealOutputDerivatives");
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentCommunicationPoint)
{
    (void)noSetFMUStatePriorToCurrentCommunicationPoint;
    return (fmi2Status)fs_inst_do_step(INST, currentCommunicationPoint, communicationStepSize);
}

fmi2Status fmi2CancelStep(fmi2Component c) { return (fmi2Status)fs_inst_unsupported(INST, "fmi2CancelStep"); }

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value)
{
    if (s != fmi2DoStepStatus) return (fmi2Status)fs_inst_unsupported(INST, "fmi2GetStatus of this kind");
    *value = INST->state == FS_INST_STOPPED ? fmi2Discard : fmi2OK;
    return fmi2OK;
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value)
{
    if (s != fmi2LastSuccessfulTime) return (fmi2Status)fs_inst_unsupported(INST, "fmi2GetRealStatus of this kind");
    *value = INST->t;
    return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value)
{
    (void)s, (void)value;
    return (fmi2Status)fs_inst_unsupported(INST, "fmi2GetIntegerStatus");
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value)
{
    if (s != fmi2Terminated) return (fmi2Status)fs_inst_unsupported(INST, "fmi2GetBooleanStatus of this kind");
    *value = INST->state == FS_INST_STOPPED;
    return fmi2OK;
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value)
{
    (void)s, (void)value;
    return (fmi2Status)fs_inst_unsupported(INST, "fmi2GetStringStatus");
}

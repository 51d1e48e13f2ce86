/* ==== The controller (both targets): sim-core's controller.rs and sensors ==== */

/* Resets nodes start..end-1 (a whole sub-tree when `end` is a subtree_end): zero state, the
 * rest firing rates, no inputs, zero outputs, no active child. */
static void reset_nodes(hevo_state *state, unsigned start, unsigned end)
{
    unsigned node_idx, i;
    for (node_idx = start; node_idx < end && node_idx < HEVO_N_NODES; node_idx++) {
        const hevo_node *node = &hevo_nodes[node_idx];
        hevo_value *presyn = &state->presyn[node->presyn_offset];
        for (i = 0; i < node->n_hidden; i++) {
            state->y[node->hidden_offset + i] = VALUE_ZERO;
            presyn[node->n_inputs + i] = node->rest_firing[i];
        }
        for (i = 0; i < node->n_inputs; i++) {
            presyn[i] = VALUE_ZERO;
        }
        for (i = 0; i < node->n_outputs; i++) {
            state->outputs[node->output_offset + i] = VALUE_ZERO;
        }
        state->active_child[node_idx] = -1;
        state->active_for[node_idx] = 0;
    }
}

/* Index of the largest value, the lowest on ties. */
static unsigned argmax(const hevo_value *values, unsigned n)
{
    unsigned best_idx = 0, i;
    hevo_value best_value = VALUE_LOWEST;
    for (i = 0; i < n; i++) {
        if (values[i] > best_value) {
            best_idx = i;
            best_value = values[i];
        }
    }
    return best_idx;
}

void hevo_decide(hevo_state *state, hevo_wheel_outputs *wheels)
{
    unsigned node_idx = 0, iteration, i;
    state->path_len = 0;
    wheels->left = VALUE_ZERO;
    wheels->right = VALUE_ZERO;
    /* Each descent goes to a child, whose index is larger: a primitive within N_NODES. */
    for (iteration = 0; iteration < HEVO_N_NODES; iteration++) {
        const hevo_node *node = &hevo_nodes[node_idx];
        hevo_value *presyn = &state->presyn[node->presyn_offset];
        hevo_value *outputs = &state->outputs[node->output_offset];
        unsigned chosen;
        int previous;
        if (state->path_len < HEVO_MAX_PATH) {
            state->path[state->path_len++] = (uint16_t)node_idx;
        }
        for (i = 0; i < node->n_inputs; i++) {
            presyn[i] = state->inputs[node->input_index[i]];
        }
        euler_step(node, presyn, &state->y[node->hidden_offset], outputs);
        if (!node->is_arbitrator) {
            wheels->left = outputs[0];
            wheels->right = outputs[1];
            break;
        }
        /* sim-core's arbitrate: the argmax, unless the active child is still within its
         * minimum; leaving a child resets its sub-tree. */
        chosen = argmax(outputs, node->n_outputs);
        previous = state->active_child[node_idx];
        if (previous >= 0 && state->active_for[node_idx] < node->min_active_cycles) {
            chosen = (unsigned)previous;
        }
        state->active_child[node_idx] = (int16_t)chosen;
        if (previous == (int)chosen) {
            if (state->active_for[node_idx] != UINT32_MAX) {
                state->active_for[node_idx]++;
            }
        } else {
            state->active_for[node_idx] = 1;
            if (previous >= 0) {
                unsigned left_node = hevo_children[node->first_child + (unsigned)previous];
                reset_nodes(state, left_node, hevo_nodes[left_node].subtree_end);
            }
        }
        node_idx = hevo_children[node->first_child + chosen];
    }
    wheel_speeds(wheels);
}

void hevo_sense(hevo_state *state, const hevo_raw_inputs *raw)
{
    unsigned i;
    for (i = 0; i < HEVO_N_INPUTS; i++) {
        state->inputs[i] = VALUE_ZERO;
    }
    if (hevo_live_ir) {
        for (i = 0; i < HEVO_N_IR; i++) {
            state->inputs[i] = ir_input(raw->ir[i], state->ir_gain[i]);
        }
    }
    if (hevo_live_light) {
        /* sim-core's FlashDetector: a detection (re)arms the hold; the input is 1 while it
         * lasts, counted down after each cycle's input. */
        for (i = 0; i < HEVO_N_LIGHT; i++) {
            if (raw->light[i] < hevo_light_threshold[i]) {
                state->flash_remaining[i] = hevo_light_hold;
            }
            if (state->flash_remaining[i] > 0u) {
                state->inputs[HEVO_N_IR + i] = VALUE_ONE;
                state->flash_remaining[i]--;
            }
        }
    }
    if (hevo_live_near_robot) {
        state->inputs[HEVO_N_IR + HEVO_N_LIGHT] = raw->near_robot ? VALUE_ONE : VALUE_ZERO;
    }
}

void hevo_reset(hevo_state *state)
{
    unsigned i;
    reset_nodes(state, 0u, HEVO_N_NODES);
    state->path_len = 0;
    for (i = 0; i < HEVO_N_LIGHT; i++) {
        state->flash_remaining[i] = 0;
    }
    for (i = 0; i < HEVO_N_INPUTS; i++) {
        state->inputs[i] = VALUE_ZERO;
    }
}

void hevo_init(hevo_state *state)
{
    unsigned i;
    memset(state, 0, sizeof *state);
    for (i = 0; i < HEVO_N_IR; i++) {
        state->ir_gain[i] = VALUE_ONE;
    }
    hevo_reset(state);
}

void hevo_set_ir_gain(hevo_state *state, unsigned sensor, hevo_value gain)
{
    if (sensor < HEVO_N_IR) {
        state->ir_gain[sensor] = gain;
    }
}

void hevo_step(hevo_state *state, const hevo_raw_inputs *raw, hevo_wheel_outputs *wheels)
{
    hevo_sense(state, raw);
    hevo_decide(state, wheels);
}

int hevo_root_choice(const hevo_state *state)
{
    return hevo_nodes[0].is_arbitrator ? state->active_child[0] : -1;
}
